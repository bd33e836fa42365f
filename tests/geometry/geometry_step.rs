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

/// sRGB `#RRGGBB` as the linear RGB OpenCASCADE keeps (and `XFindColor` takes).
fn linear_rgb(hex: &str) -> [f64; 3] {
    let h = hex.trim_start_matches('#');
    let lin = |c: f64| {
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    [0, 2, 4].map(|i| lin(f64::from(u8::from_str_radix(&h[i..i + 2], 16).unwrap()) / 255.0))
}

/// One part the assembled STEP must hold: the manifest's name, the colour of its
/// piece in `module-assembled.3mf` (a separate writer), and its exact volume.
struct ExpectedPart {
    name: String,
    colour: String,
    volume_mm3: f64,
}

/// The parts of the assembled module as the manifest and the assembled 3MF list them.
fn expected_assembly(out: &Path, r: &fbgforge::geometry::BuildReport) -> Vec<ExpectedPart> {
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    let asm = fbgforge::geometry::threemf::read(
        &std::fs::read(out.join("module-assembled.3mf")).unwrap(),
    )
    .unwrap();
    let mut kinds = Vec::new();
    let names: Vec<String> = m["parts"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| ["cap", "core", "insert"].contains(&p["kind"].as_str().unwrap()))
        .filter(|p| {
            let first = !kinds.contains(&p["kind"]);
            kinds.push(p["kind"].clone());
            first
        })
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(names.len(), asm.objects.len());
    names
        .into_iter()
        .zip(&asm.objects)
        .map(|(name, o)| ExpectedPart {
            volume_mm3: r
                .parts
                .iter()
                .find(|p| p.name == name)
                .unwrap()
                .exact_volume_mm3,
            colour: asm.materials[o.material].colour.clone(),
            name,
        })
        .collect()
}

/// The Draw script that reads `path` with XDE and prints the root, and per component
/// its name, its part's name, colour, the colour found at the expected value, and
/// the part's volume.
fn xde_script(i: usize, path: &Path, parts: &[ExpectedPart]) -> String {
    let mut s = format!(
        "ReadStep D{i} {}\nputs \"FREE {i} [llength [XGetFreeShapes D{i}]]\"\nset root [lindex [XGetFreeShapes D{i}] 0]\nputs \"ROOT {i} [GetName D{i} $root]|[XNbComponents D{i} $root]\"\n",
        path.display()
    );
    for (k, p) in parts.iter().enumerate() {
        let [r, g, b] = linear_rgb(&p.colour);
        s.push_str(&format!(
            "set ref [XGetReferredShape D{i} $root:{c}]\nset want [XFindColor D{i} {r:.6} {g:.6} {b:.6}]\nset wn none\nif {{$want ne {{}}}} {{ set wn [XGetColor D{i} $want] }}\nputs \"PART {i} {k} [GetName D{i} $root:{c}]|[GetName D{i} $ref]|[XGetShapeColor D{i} $ref surface]|$wn\"\nXGetShape v{i}_{k} D{i} $ref\nputs \"VOLUME {i} {k} [lindex [regexp -inline {{Mass :\\s+(\\S+)}} [vprops v{i}_{k}]] 1]\"\n",
            c = k + 1
        ));
    }
    s
}

/// Issue 39: the assembled module is an assembly a CAD program opens as one: a root
/// named `module-assembled` with one component per part, each named as in the
/// manifest, coloured as its piece in the assembled 3MF, and of its exact volume.
#[test]
fn opencascade_xde_reads_the_assembly_names_colours_and_tree() {
    let Some(draw) = find_on_path("occt-draw") else {
        if std::env::var_os("CI").is_some() {
            panic!("occt-draw is not installed (apt-get install -y occt-draw); CI requires it");
        }
        eprintln!("notice: occt-draw not found, SKIPPING the XDE assembly check");
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let libs = tmp.path().join("lib");
    std::fs::create_dir(&libs).unwrap();
    assert!(link_occt_libraries(&libs) > 0, "no libTK*.so.7 found");
    let mut script = String::from("pload ALL\n");
    let mut designs = Vec::new();
    for (_, design) in load_designs(&designs_dir()).unwrap() {
        let out = tmp.path().join(&design.name);
        let r = crate::build(&design, &out, None).unwrap();
        if r.fibers.is_empty() {
            continue;
        }
        let parts = expected_assembly(&out, &r);
        script.push_str(&xde_script(
            designs.len(),
            &out.join("module-assembled.step"),
            &parts,
        ));
        designs.push((design.name.clone(), parts));
    }
    assert!(designs.len() >= 4, "{} module designs", designs.len());
    script.push_str("exit\n");
    let script_path = tmp.path().join("xde.tcl");
    std::fs::write(&script_path, &script).unwrap();
    let o = Command::new(draw)
        .args(["-b", "-f"])
        .arg(&script_path)
        .env("LD_LIBRARY_PATH", &libs)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    let line = |prefix: String| -> String {
        text.lines()
            .find_map(|l| l.strip_prefix(&prefix))
            .unwrap_or_else(|| panic!("no `{prefix}` in\n{text}"))
            .to_string()
    };
    for (i, (design, parts)) in designs.iter().enumerate() {
        assert_eq!(line(format!("FREE {i} ")), "1", "{design}: one root");
        assert_eq!(
            line(format!("ROOT {i} ")),
            format!("module-assembled|{}", parts.len()),
            "{design}: the root and its children"
        );
        for (k, p) in parts.iter().enumerate() {
            let got = line(format!("PART {i} {k} "));
            let f: Vec<&str> = got.split('|').collect();
            assert_eq!(f[0], p.name, "{design}: component {k}'s name");
            assert_eq!(f[1], p.name, "{design}: part {k}'s name");
            assert_ne!(
                f[3], "none",
                "{design} {}: colour {} not in the file",
                p.name, p.colour
            );
            assert_eq!(f[2], f[3], "{design} {}: colour {}", p.name, p.colour);
            let v: f64 = line(format!("VOLUME {i} {k} ")).parse().unwrap();
            assert!(
                (v - p.volume_mm3).abs() < 1e-5 * p.volume_mm3,
                "{design} {}: OpenCASCADE volume {v} vs exact {}",
                p.name,
                p.volume_mm3
            );
        }
    }
}
