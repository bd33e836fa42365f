//! `fbgforge build`: design spec to STL, STEP, 3MF, previews and manifest; `fbgforge` with no
//! arguments builds every shipped design.

use super::progress::Bar;
use anyhow::{bail, Result};
use clap::Args;
use fbgforge::geometry;
use fbgforge::progress::Progress;
use fbgforge::spec::Design;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[];

/// Arguments of `fbgforge build`.
#[derive(Debug, Args)]
pub struct BuildArgs {
    /// The design spec (TOML).
    pub design: PathBuf,
    /// Output folder [default: out/<design name>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Meshing chord tolerance, mm [default: half the printer's resolution].
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Comma-separated parts to build (cap, core, insert-<name>, mold) [default: all].
    #[arg(long, value_delimiter = ',')]
    pub parts: Option<Vec<String>>,
}

fn default_out(design: &Design) -> PathBuf {
    Path::new("out").join(&design.name)
}

fn print_table(design: &str, r: &geometry::BuildReport) {
    println!("{design} -> {}", r.dir.display());
    println!(
        "  {:<20} {:>9} {:>14} {:>14} {:>9} {:>9}",
        "part", "triangles", "mesh mm³", "exact mm³", "error %", "tol mm"
    );
    for p in &r.parts {
        println!(
            "  {:<20} {:>9} {:>14.3} {:>14.3} {:>9.4} {:>9.4}",
            p.name,
            p.mesh.triangles.len(),
            p.mesh_volume_mm3,
            p.exact_volume_mm3,
            p.volume_error() * 100.0,
            p.mesh_tolerance_mm
        );
    }
}

/// `fbgforge build`.
pub fn run(a: BuildArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let dir = a.out.clone().unwrap_or_else(|| default_out(&design));
    let r = geometry::build_design(&design, &dir, a.tolerance, a.parts.as_deref())?;
    print_table(&design.name, &r);
    println!(
        "  wrote {} files (STL, STEP, 3MF, SVG previews, manifest.json)",
        r.files.len()
    );
    Ok(())
}

/// `fbgforge` with no arguments: build the shipped default designs into `out/`.
pub fn run_default() -> Result<()> {
    let designs = fbgforge::design::load_designs(&fbgforge::design::designs_dir())?;
    if designs.is_empty() {
        bail!(
            "no designs found in {}",
            fbgforge::design::designs_dir().display()
        );
    }
    let t = Instant::now();
    let pb = Bar::with("build", designs.len() as u64);
    let mut reports = Vec::new();
    for (_, d) in &designs {
        reports.push((
            d.name.clone(),
            geometry::build_design(d, &default_out(d), None, None)?,
        ));
        pb.advance(1);
    }
    pb.end();
    for (name, r) in &reports {
        print_table(name, r);
    }
    let files: usize = reports.iter().map(|(_, r)| r.files.len()).sum();
    println!(
        "built {} designs, {} files in {:.2} s; open the STL files in your slicer (see README)",
        reports.len(),
        files,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
