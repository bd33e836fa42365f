//! Helpers shared by the integration tests: the shipped designs, by file name.
//! (Each `tests/*.rs` is its own crate and uses only some of these.)
#![allow(dead_code)]

use fbgforge::spec::Design;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// The `fbgforge` binary that `cargo test` built beside the tests, run from the
/// repository's root (so shipped designs and fixtures resolve as a user types them).
pub fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_fbgforge"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// Start a `synth-stream` command (its standard output piped here) and read the
/// address it prints first: the running child and `tcp://127.0.0.1:PORT`.
pub fn spawn_stream(mut synth_stream: Command) -> (Child, String) {
    let mut child = synth_stream
        .stdout(Stdio::piped())
        .spawn()
        .expect("synth-stream starts");
    let mut first = String::new();
    BufReader::new(child.stdout.as_mut().unwrap())
        .read_line(&mut first)
        .unwrap();
    let port = first
        .trim()
        .rsplit(':')
        .next()
        .unwrap_or_default()
        .to_string();
    (child, format!("tcp://127.0.0.1:{port}"))
}

/// Path of a shipped design (`designs/<name>`), independent of the working directory.
pub fn shipped_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("designs")
        .join(name)
}

/// A shipped design, loaded and validated; panics with the loader's message.
pub fn shipped(name: &str) -> Design {
    fbgforge::design::load(&shipped_path(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// Set one material's Young's modulus, MPa (the material must exist in the design).
pub fn set_modulus(d: &mut Design, material: &str, mpa: f64) {
    d.materials
        .get_mut(material)
        .unwrap_or_else(|| panic!("no material {material}"))
        .youngs_modulus_mpa = mpa;
}

/// clip-on-34mm with `lambda_11` made 30 mm long and centred 40 mm up its core (the
/// highest centre the spec allows), so it reaches from the cylinder into the zone
/// under the dome where the strain changes fast (17 µε/N from end to end), written
/// weak (Δn = 3·10⁻⁵, κL ≈ 1.8, FWHM ≈ 46 pm) and rated for 10 N.
pub fn long_grating_design() -> Design {
    let mut d = shipped("clip-on-34mm.toml");
    d.fiber.index_modulation = 3e-5;
    let m = d.module.as_mut().unwrap();
    let g = m
        .gratings
        .iter_mut()
        .find(|g| g.name == "lambda_11")
        .unwrap();
    g.length_mm = 30.0;
    g.center_height_mm = Some(40.0);
    m.limits = Some(fbgforge::spec::Limits {
        max_force_n: 10.0,
        max_grating_strain_microstrain: 3000.0,
    });
    d
}
