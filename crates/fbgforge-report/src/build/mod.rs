//! How a build is shown: the implementations of [`fbgforge_geometry::BuildSink`].
//!
//! - [`Previews`]: the cut-away previews of the checked parts (`preview-module.svg`,
//!   `preview-mold.svg`), written with the parts and listed in the manifest;
//! - [`BuildTable`]: each part's mesh against its exact volume, printed as each design
//!   is built; [`BuildTables`] holds the tables of several designs until
//!   [`BuildTables::finish`] prints them with the total.

pub mod preview;

use anyhow::Result;
use fbgforge_core::spec::Design;
use fbgforge_geometry::{BuildReport, BuildSink, CheckedBuild};
use std::fmt::Write as _;
use std::io::Write;
use std::time::Duration;

/// The cut-away previews: the assembled module (when it was built whole, its fibers
/// traced) and the mold.
#[derive(Debug, Clone, Copy, Default)]
pub struct Previews;

impl BuildSink for Previews {
    fn drawings(&mut self, b: &CheckedBuild) -> Result<Vec<(String, Vec<u8>)>> {
        let mut out = Vec::new();
        if let Some(svg) = b
            .fibers
            .and_then(|f| preview::module_svg(b.profile, b.parts, f))
        {
            out.push(("preview-module.svg".to_string(), svg.into_bytes()));
        }
        if let Some(svg) = preview::mold_svg(b.profile, b.parts) {
            out.push(("preview-mold.svg".to_string(), svg.into_bytes()));
        }
        Ok(out)
    }
}

/// One design's table: the folder, then each part's triangles, volumes, error and
/// tolerance.
fn table(design: &str, r: &BuildReport) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{design} -> {}", r.dir.display());
    let _ = writeln!(
        s,
        "  {:<20} {:>9} {:>12} {:>12} {:>9} {:>9}",
        "part", "triangles", "mesh mm³", "exact mm³", "error %", "tol mm"
    );
    for p in &r.parts {
        let _ = writeln!(
            s,
            "  {:<20} {:>9} {:>12.3} {:>12.3} {:>9.4} {:>9.4}",
            p.name,
            p.mesh.triangles.len(),
            p.mesh_volume_mm3,
            p.exact_volume_mm3,
            p.volume_error() * 100.0,
            p.mesh_tolerance_mm
        );
    }
    // The gap the meshes keep of each designed one: the narrowest share.
    if let Some(g) = r
        .gaps
        .iter()
        .min_by(|a, b| a.kept_percent.total_cmp(&b.kept_percent))
    {
        let _ = writeln!(
            s,
            "  {} designed gaps kept in the meshes, the least {:.1} % ({}: {:.4} of {:.4} mm)",
            r.gaps.len(),
            g.kept_percent,
            g.what,
            g.meshed_gap_mm,
            g.designed_gap_mm
        );
    }
    for w in &r.warnings {
        let _ = writeln!(s, "  warning: {w}");
    }
    s
}

/// A build's table, then how many files it wrote.
pub struct BuildTable<W: Write> {
    out: W,
}

impl<W: Write> BuildTable<W> {
    /// A table printed to `out`.
    pub fn new(out: W) -> Self {
        BuildTable { out }
    }
}

impl<W: Write> BuildSink for BuildTable<W> {
    fn built(&mut self, design: &Design, r: &BuildReport) -> Result<()> {
        let text = format!(
            "{}  wrote {} files (STL, STEP, 3MF, SVG previews, manifest.json); to print: {}\n",
            table(&design.name, r),
            r.files.len(),
            r.dir.join("parts.3mf").display()
        );
        write!(self.out, "{}", crate::terminal::fit(&text))?;
        Ok(())
    }
}

/// The tables of several builds, held until [`BuildTables::finish`] prints them (so a
/// progress bar drawn meanwhile is not interleaved with them) and the total.
pub struct BuildTables<W: Write> {
    out: W,
    tables: Vec<String>,
    files: usize,
}

impl<W: Write> BuildTables<W> {
    /// Tables printed to `out` at the end.
    pub fn new(out: W) -> Self {
        BuildTables {
            out,
            tables: Vec::new(),
            files: 0,
        }
    }

    /// Print every table, then the number of designs and files and the time they took.
    pub fn finish(mut self, elapsed: Duration) -> Result<()> {
        let mut text = self.tables.concat();
        let _ = writeln!(
            text,
            "built {} designs, {} files in {:.2} s; to print: out/<name>/parts.3mf",
            self.tables.len(),
            self.files,
            elapsed.as_secs_f64()
        );
        write!(self.out, "{}", crate::terminal::fit(&text))?;
        Ok(())
    }
}

impl<W: Write> BuildSink for BuildTables<W> {
    fn built(&mut self, design: &Design, r: &BuildReport) -> Result<()> {
        self.tables.push(table(&design.name, r));
        self.files += r.files.len();
        Ok(())
    }
}
