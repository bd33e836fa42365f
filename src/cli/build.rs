//! `fbgforge build`: design spec to STL, STEP, 3MF, previews and manifest; `fbgforge` with no
//! arguments builds every shipped design.

use super::progress::Bar;
use anyhow::{bail, Result};
use clap::Args;
use fbgforge::geometry::{self, BuildRequest};
use fbgforge::progress::Progress;
use fbgforge::report::build::{BuildTable, BuildTables, Previews};
use fbgforge::spec::Design;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    ("BuildRequest.parts", "--parts"),
    ("BuildRequest.tolerance_mm", "--tolerance"),
];

/// Arguments of `fbgforge build`.
#[derive(Debug, Args)]
pub struct BuildArgs {
    /// The design spec (TOML), or a shipped design's name (`clip-on-34mm`).
    #[arg(value_parser = super::designs::design_arg)]
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

/// `fbgforge build`.
pub fn run(a: BuildArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let dir = a.out.clone().unwrap_or_else(|| default_out(&design));
    let request = BuildRequest {
        tolerance_mm: a.tolerance,
        parts: a.parts.clone(),
    };
    let mut sink = geometry::WithWarnings {
        warnings: design_warnings(&design)?,
        sink: (Previews, BuildTable::new(std::io::stdout())),
    };
    geometry::build_design(&design, &dir, &request, &mut sink)?;
    Ok(())
}

/// What the models find about a design at build time: a grating whose reflection
/// chirps or splits inside the force range (module: the FE strain profile over
/// `[module.limits]`; array: the sheet model's under each cell up to `ulimit_g`).
fn design_warnings(design: &Design) -> Result<Vec<String>> {
    let mut w = fbgforge::prediction::spectrum::design_warnings(
        design,
        &fbgforge::fem::GeometryCache::default(),
    )?;
    if design.array.is_some() && design.module.is_none() {
        let p = fbgforge::array::predict::ArrayPredictor::new(design, None)?;
        if let Some(s) = p.spectra(design)? {
            w.extend(s.warnings);
        }
    }
    Ok(w)
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
    let mut tables = BuildTables::new(std::io::stdout());
    for (_, d) in &designs {
        let mut sink = geometry::WithWarnings {
            warnings: design_warnings(d)?,
            sink: (Previews, &mut tables),
        };
        geometry::build_design(d, &default_out(d), &BuildRequest::default(), &mut sink)?;
        pb.advance(1);
    }
    pb.end();
    tables.finish(t.elapsed())
}
