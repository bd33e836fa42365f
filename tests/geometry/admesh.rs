//! The shipped designs' STL files checked by an outside tool, admesh (Debian package
//! `admesh`): one part per file, no disconnected facets, nothing fixed or reversed, no
//! degenerate facets, and the volume it reports equal to the manifest's mesh volume.
//!
//! Without admesh the test fails when `CI` is set (`.ci/run` installs it) and is
//! skipped with a notice otherwise.

use fbgforge::design::{designs_dir, load_designs};
use std::process::Command;

/// The numbers admesh prints, by label.
fn field(report: &str, label: &str) -> f64 {
    // Lines look like "Number of parts       :     1        Volume   :  9707.718750"
    // or "Edges fixed           :     0"; a label may share its line with another.
    for line in report.lines() {
        if let Some(pos) = line.find(label) {
            let rest = &line[pos + label.len()..];
            let rest = rest.trim_start().trim_start_matches(':').trim_start();
            let num: String = rest.chars().take_while(|c| !c.is_whitespace()).collect();
            if let Ok(v) = num.parse() {
                return v;
            }
        }
    }
    panic!("admesh output has no `{label}`:\n{report}");
}

#[test]
fn admesh_accepts_every_shipped_stl() {
    if Command::new("admesh").arg("--version").output().is_err() {
        if std::env::var_os("CI").is_some() {
            panic!("admesh is not installed (apt-get install -y admesh); CI requires it");
        }
        eprintln!(
            "notice: admesh not found, skipping the outside STL check (apt-get install -y admesh)"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    for (_, design) in load_designs(&designs_dir()).unwrap() {
        let out = dir.path().join(&design.name);
        crate::build(&design, &out, None).unwrap();
        let manifest: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap())
                .unwrap();
        for entry in manifest["parts"].as_array().unwrap() {
            let name = entry["name"].as_str().unwrap();
            let stl = out.join(entry["stl"].as_str().unwrap());
            let o = Command::new("admesh").arg(&stl).output().unwrap();
            assert!(o.status.success(), "admesh failed on {}", stl.display());
            let text = String::from_utf8_lossy(&o.stdout);
            let what = format!("{} {name}", design.name);
            assert_eq!(field(&text, "Number of parts"), 1.0, "{what}\n{text}");
            for label in [
                "Total disconnected facets",
                "Degenerate facets",
                "Edges fixed",
                "Facets removed",
                "Facets added",
                "Facets reversed",
                "Backwards edges",
                "Normals fixed",
            ] {
                assert_eq!(field(&text, label), 0.0, "{what}: {label}\n{text}");
            }
            assert_eq!(
                field(&text, "Number of facets") as u64,
                entry["triangles"].as_u64().unwrap(),
                "{what}"
            );
            let v = field(&text, "Volume");
            // admesh reads f32 coordinates and prints 6 decimals.
            let mv = entry["mesh_volume_mm3"].as_f64().unwrap();
            assert!(
                (v - mv).abs() < 1e-5 * mv,
                "{what}: admesh volume {v} vs manifest {mv}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 16, "only {checked} files checked");
}
