//! Loading a design: parse the TOML spec ([`crate::spec`]), check every field, then
//! check what needs the derived profile ([`crate::profile`]): the radial stack, the
//! pillar pitch, the holes against the domes. Every command loads designs here, so a
//! design that loads is one the geometry, the model and the verifier can trust.
//!
//! This sits above both `spec` and `profile`, so neither imports the other's caller.

use crate::profile::ModuleProfile;
use crate::spec::{err, range, Design, GratingRole, Module, SpecError};
use std::path::{Path, PathBuf};

/// Load a design from a TOML file and validate it.
pub fn load(path: &Path) -> Result<Design, SpecError> {
    let text = std::fs::read_to_string(path).map_err(|e| SpecError {
        file: Some(path.to_path_buf()),
        field: String::new(),
        message: format!("cannot read the design file: {e}"),
    })?;
    parse(&text).map_err(|mut e| {
        e.file = Some(path.to_path_buf());
        e
    })
}

/// Parse and validate a design from TOML text.
pub fn parse(text: &str) -> Result<Design, SpecError> {
    let design = crate::spec::parse_unvalidated(text)?;
    design.validate()?;
    Ok(design)
}

impl Design {
    /// Check every field against its allowed range and every cross-field constraint,
    /// those on the derived profile included.
    pub fn validate(&self) -> Result<(), SpecError> {
        self.validate_fields()?;
        if let Some(m) = &self.module {
            check_profile(m, self.printer.min_wall_mm)?;
            check_grating_heights(m)?;
        }
        Ok(())
    }
}

/// The module's constraints on its derived profile.
fn check_profile(m: &Module, min_wall: f64) -> Result<(), SpecError> {
    let r = m.outer_diameter_mm / 2.0;
    let pl = &m.pillars;
    // Radial stack: the core and an insert must keep a positive radius.
    let prof = ModuleProfile::from_module_unchecked(m);
    if prof.core_inner_radius_mm < 0.25 * r || prof.core_inner_radius_mm <= 0.0 {
        return Err(err(
                "module.cap_wall_mm",
                format!(
                    "walls, clearance and pillars ({:.3} mm in all) leave the core an inner radius of {:.3} mm; at least a quarter of the outer radius ({:.3} mm) is needed: reduce the walls or the pillar height",
                    r - prof.core_inner_radius_mm,
                    prof.core_inner_radius_mm,
                    0.25 * r
                ),
            ));
    }
    // Pillars must not overlap: their angular width at the core wall, plus a gap of
    // one minimum wall between neighbours, must fit in the circumference.
    let pitch_mm = 2.0 * std::f64::consts::PI * prof.core_outer_radius_mm / pl.count as f64;
    if pl.width_mm + min_wall > pitch_mm * 0.8 {
        return Err(err(
                "module.pillars.width_mm",
                format!(
                    "{} pillars of {} mm overlap on a core wall of radius {:.3} mm; allowed up to {:.3} mm each",
                    pl.count,
                    pl.width_mm,
                    prof.core_outer_radius_mm,
                    pitch_mm * 0.8 - min_wall
                ),
            ));
    }
    if m.top_hole_diameter_mm / 2.0 >= prof.core_dome_inner_sphere_radius_mm * 0.5 {
        return Err(err(
            "module.top_hole_diameter_mm",
            format!(
                "allowed up to {:.3} mm (the core's inner dome radius)",
                prof.core_dome_inner_sphere_radius_mm
            ),
        ));
    }
    if m.apex_flat_diameter_mm / 2.0 >= prof.insert_sphere_radius_mm * 0.5 {
        return Err(err(
            "module.apex_flat_diameter_mm",
            format!("allowed up to {:.3} mm", prof.insert_sphere_radius_mm),
        ));
    }
    if prof.insert_radius_mm < min_wall {
        return Err(err(
            "module.core_insert_clearance_mm",
            format!(
                "leaves the insert a radius of {:.3} mm",
                prof.insert_radius_mm
            ),
        ));
    }
    if prof.pillar_top_mm < 2.0 * min_wall.max(1.0) {
        return Err(err(
                "module.overall_height_mm",
                format!(
                    "{} mm leaves a cylindrical section of {:.3} mm below the dome; make the module taller or the dome lower",
                    m.overall_height_mm, prof.pillar_top_mm
                ),
            ));
    }
    Ok(())
}

/// The folder of shipped designs: `designs/` under the working directory, else the
/// crate's own.
pub fn designs_dir() -> PathBuf {
    let local = PathBuf::from("designs");
    if local.is_dir() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("designs")
    }
}

/// Every `*.toml` in `dir`, loaded and validated, sorted by file name.
pub fn load_designs(dir: &Path) -> anyhow::Result<Vec<(PathBuf, Design)>> {
    use anyhow::Context;
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read the designs folder {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let d = load(&p)?;
            Ok((p, d))
        })
        .collect()
}

/// Each strain grating lies wholly on the cylindrical part of its pillar.
fn check_grating_heights(m: &Module) -> Result<(), SpecError> {
    let prof = ModuleProfile::from_module_unchecked(m);
    for (i, g) in m.gratings.iter().enumerate() {
        if let (GratingRole::Strain, Some(z)) = (g.role, g.center_height_mm) {
            let lo = g.length_mm / 2.0;
            let hi = prof.pillar_top_mm - g.length_mm / 2.0;
            range(&format!("module.gratings[{i}].center_height_mm"), z, lo, hi)?;
        }
    }
    Ok(())
}
