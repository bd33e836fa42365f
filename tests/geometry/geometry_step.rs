//! The STEP files checked by an outside CAD kernel: OpenCASCADE's DRAW interpreter
//! (Debian package `occt-draw`) reads each shipped part's STEP and each assembled
//! module's, `checkshape` must find it valid, and the volume OpenCASCADE integrates on
//! the exact B-rep (`vprops`) must equal our closed-form volume (for the assembly, the
//! sum of its parts').
//!
//! `.ci/run` installs `occt-draw`, so in CI (`CI` set) a missing checker fails the
//! test; elsewhere it is skipped with a notice. The reader must also report no error
//! (truck-stepio's own header used to give "Unresolved Reference: Fails Count: 2").
//! Debian's DRAW loads its plug-ins by unversioned names (`libTKTopTest.so`) that only
//! the -dev packages provide, so the test points it at a temporary folder of symlinks
//! to the versioned libraries.

use fbgforge::design::{designs_dir, load_designs};
use std::path::{Path, PathBuf};
use std::process::Command;

fn find_on_path(name: &str) -> Option<PathBuf> {
    std::env::split_paths(&std::env::var_os("PATH")?)
        .map(|d| d.join(name))
        .find(|p| p.is_file())
}

/// Symlinks `libTK*.so` → `libTK*.so.7` in `dir`, from the usual library folders.
fn link_occt_libraries(dir: &Path) -> usize {
    let mut n = 0;
    for lib in [
        "/usr/lib/x86_64-linux-gnu",
        "/usr/lib/aarch64-linux-gnu",
        "/usr/lib",
    ] {
        let Ok(entries) = std::fs::read_dir(lib) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if let Some(stem) = name.strip_suffix(".so.7") {
                if stem.starts_with("libTK") {
                    let link = dir.join(format!("{stem}.so"));
                    if !link.exists() && std::os::unix::fs::symlink(e.path(), &link).is_ok() {
                        n += 1;
                    }
                }
            }
        }
    }
    n
}

#[test]
fn opencascade_reads_every_step_as_a_valid_solid_of_the_exact_volume() {
    let Some(draw) = find_on_path("occt-draw") else {
        if std::env::var_os("CI").is_some() {
            panic!("occt-draw is not installed (apt-get install -y occt-draw); CI requires it");
        }
        eprintln!("notice: occt-draw not found, SKIPPING the outside STEP check (apt-get install -y occt-draw)");
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let libs = tmp.path().join("lib");
    std::fs::create_dir(&libs).unwrap();
    assert!(
        link_occt_libraries(&libs) > 0,
        "occt-draw is installed but no libTK*.so.7 was found"
    );

    // One STEP per distinct solid of every shipped design (the inserts are alike).
    let mut checks: Vec<(String, PathBuf, f64)> = Vec::new();
    for (_, design) in load_designs(&designs_dir()).unwrap() {
        let out = tmp.path().join(&design.name);
        let r = crate::build(&design, &out, None).unwrap();
        // The assembled module: one file, a solid per part, their volumes summed.
        if !r.fibers.is_empty() {
            let mut kinds = Vec::new();
            let total: f64 = r
                .parts
                .iter()
                .filter(|p| p.kind.part().in_module())
                .filter(|p| {
                    let first = !kinds.contains(&p.kind);
                    kinds.push(p.kind);
                    first
                })
                .map(|p| p.exact_volume_mm3)
                .sum();
            checks.push((
                format!("{} assembled module", design.name),
                out.join("module-assembled.step"),
                total,
            ));
        }
        let mut seen = Vec::new();
        for p in &r.parts {
            if seen.contains(&p.kind) {
                continue;
            }
            seen.push(p.kind);
            checks.push((
                format!("{} {}", design.name, p.name),
                out.join(format!("{}.step", p.name)),
                p.exact_volume_mm3,
            ));
        }
    }
    let mut script = String::from("pload MODELING DATAEXCHANGE\n");
    for (i, (_, path, _)) in checks.iter().enumerate() {
        script.push_str(&format!(
            "stepread {} s{i} *\nputs \"PART {i}\"\nputs [checkshape s{i}_1]\nputs [vprops s{i}_1]\n",
            path.display()
        ));
    }
    script.push_str("exit\n");
    let script_path = tmp.path().join("check.tcl");
    std::fs::write(&script_path, script).unwrap();
    let o = Command::new(draw)
        .arg("-b")
        .arg("-f")
        .arg(&script_path)
        .env("LD_LIBRARY_PATH", &libs)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    for bad in ["ERR", "Unresolved", "Fail"] {
        assert!(!text.contains(bad), "OpenCASCADE reports `{bad}`:\n{text}");
    }
    for (i, (what, _, exact)) in checks.iter().enumerate() {
        let start = text
            .find(&format!("PART {i}\n"))
            .unwrap_or_else(|| panic!("{what}: no output\n{text}"));
        let end = text[start + 1..]
            .find("PART ")
            .map_or(text.len(), |e| start + 1 + e);
        let block = &text[start..end];
        assert!(
            block.contains("This shape seems to be valid"),
            "{what}: checkshape\n{block}"
        );
        let mass: f64 = block
            .lines()
            .find_map(|l| {
                l.trim()
                    .strip_prefix("Mass :")
                    .map(|v| v.trim().parse().unwrap())
            })
            .unwrap_or_else(|| panic!("{what}: no volume\n{block}"));
        // vprops prints six significant digits.
        assert!(
            (mass - exact).abs() < 1e-5 * exact,
            "{what}: OpenCASCADE volume {mass} vs exact {exact}"
        );
    }
    assert!(checks.len() >= 17, "{} STEP files checked", checks.len());
}
