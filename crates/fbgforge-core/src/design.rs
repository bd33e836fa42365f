//! Loading a design: parse the TOML spec ([`crate::spec`]), check every field, then
//! check what needs the derived profile ([`crate::profile`]): the radial stack, the
//! pillar pitch, the holes against the domes. Every command loads designs here, so a
//! design that loads is one the geometry, the model and the verifier can trust.
//!
//! This sits above both `spec` and `profile`, so neither imports the other's caller.

use crate::profile::{module_gratings, snap_report, ModuleProfile, PartsProfile, ReferenceChamber};
use crate::spec::{
    err, free_intervals, intervals_words, range, Design, GratingRole, Module, SpecError,
    GRATING_END_GAP_MM,
};
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
    let mut design = crate::spec::parse_unvalidated(text)?;
    design.fill_derived();
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
            check_parts(self, m)?;
        }
        Ok(())
    }
}

/// What to change when a fiber cannot bend out below a grating.
const BEND_ADVICE: &str = "raise the grating, lower fiber_routing.exit_height_mm, or use a fiber with a smaller fiber_routing.min_bend_radius_mm (bend-insensitive G.657 fiber: 7.5 or 5 mm)";

/// The fiber exits, the insert's bore and the snap bead fit the module: every fiber
/// bends below its grating and above the plate, every slot stays below the features
/// over it, and the snap strains the cap's material less than it permits.
fn check_parts(d: &Design, m: &Module) -> Result<(), SpecError> {
    let Some((p, pp)) = PartsProfile::of_design(d) else {
        return Ok(());
    };
    let min_wall = d.printer.min_wall_mm;
    check_bend_heights(m, &p, &pp)?;
    check_grating_spacing(m, &p, &pp)?;
    check_top_hole(d, m)?;
    check_slots(&p, &pp, min_wall)?;
    if let Some(c) = &pp.reference_chamber {
        check_reference_chamber(m, &p, &pp, c, min_wall)?;
    }
    if pp.insert_bore_radius_mm + min_wall > p.insert_radius_mm {
        return Err(err(
            "fiber_routing.coated_diameter_mm",
            format!(
                "the reference fiber's bore (radius {:.3} mm) leaves the insert (radius {:.3} mm) no printable wall",
                pp.insert_bore_radius_mm, p.insert_radius_mm
            ),
        ));
    }
    check_snap(d, m, &p, &pp)
}

/// Every grating starts above where its fiber bends out of the module.
fn check_bend_heights(m: &Module, p: &ModuleProfile, pp: &PartsProfile) -> Result<(), SpecError> {
    let z_b = pp.bend_start_z_mm;
    for (i, g) in module_gratings(m, p).iter().enumerate() {
        if g.z_start_mm < z_b + pp.fiber_radius_mm {
            // A reference grating hangs from the top: it is raised by shortening it
            // or the fiber left past it.
            let (field, advice) = match g.role {
                GratingRole::Strain => (format!("module.gratings[{i}].center_height_mm"), BEND_ADVICE.to_string()),
                GratingRole::TemperatureReference => (
                    format!("module.gratings[{i}].length_mm"),
                    format!("shorten the grating or the fiber left past it (module.gratings[{i}].tail_mm, default {} mm), {}", crate::spec::DEFAULT_REFERENCE_TAIL_MM, BEND_ADVICE.trim_start_matches("raise the grating, ")),
                ),
            };
            return Err(err(
                &field,
                format!(
                    "grating `{}` starts at {:.3} mm, but its fiber must run straight down to {:.3} mm (exit height {} mm + minimum bend radius {} mm) before it can bend out of the module; {advice}",
                    g.name, g.z_start_mm, z_b, pp.exit_height_mm, pp.bend_radius_mm
                ),
            ));
        }
    }
    Ok(())
}

/// Two gratings on one fiber (a strain fiber: one core's pillar; the reference fiber:
/// the axis, shared by the references of one core and those serving every core) keep
/// [`GRATING_END_GAP_MM`] of fiber between their ends. The error names the later
/// grating's field and the centre heights that would work.
fn check_grating_spacing(
    m: &Module,
    p: &ModuleProfile,
    pp: &PartsProfile,
) -> Result<(), SpecError> {
    let placed = module_gratings(m, p);
    for (i, g) in m.gratings.iter().enumerate() {
        for (j, o) in m.gratings[..i].iter().enumerate() {
            let same_fiber = match (g.role, o.role) {
                (GratingRole::Strain, GratingRole::Strain) => {
                    g.core == o.core && g.pillar == o.pillar
                }
                (GratingRole::TemperatureReference, GratingRole::TemperatureReference) => {
                    g.core.is_none() || o.core.is_none() || g.core == o.core
                }
                _ => false,
            };
            if !same_fiber {
                continue;
            }
            if g.role == GratingRole::TemperatureReference {
                return Err(err(
                    &format!("module.gratings[{i}].core"),
                    format!(
                        "reference gratings `{}` and `{}` (module.gratings[{j}]) would hang on the same reference fiber in one chamber: a module carries one reference grating per core; give each its own core (module.gratings[{i}].core and module.gratings[{j}].core), or remove one",
                        g.name, o.name
                    ),
                ));
            }
            let (a, b) = (&placed[i], &placed[j]);
            let gap = a.z_start_mm.max(b.z_start_mm) - a.z_end_mm.min(b.z_end_mm);
            if gap >= GRATING_END_GAP_MM - 1e-9 {
                continue;
            }
            // Where the centre may go: on the pillar above the fiber's bend, clear
            // of every other grating on this fiber.
            let half = g.length_mm / 2.0;
            let lo = pp.bend_start_z_mm + pp.fiber_radius_mm + half;
            let hi = p.pillar_top_mm - half;
            let blocked: Vec<(f64, f64)> = m.gratings[..i]
                .iter()
                .zip(&placed)
                .filter(|(q, _)| {
                    q.role == GratingRole::Strain && q.core == g.core && q.pillar == g.pillar
                })
                .map(|(_, q)| {
                    (
                        q.z_start_mm - GRATING_END_GAP_MM - half,
                        q.z_end_mm + GRATING_END_GAP_MM + half,
                    )
                })
                .collect();
            let free = free_intervals(lo, hi, &blocked);
            return Err(err(
                &format!("module.gratings[{i}].center_height_mm"),
                format!(
                    "grating `{}` ({:.3} to {:.3} mm) and grating `{}` (module.gratings[{j}], {:.3} to {:.3} mm) lie on the same fiber (core `{}`, pillar {}) {}: two gratings on one fiber keep {GRATING_END_GAP_MM} mm of fiber between their ends; allowed {} (on the pillar above the fiber's bend, clear of the fiber's other gratings)",
                    g.name,
                    a.z_start_mm,
                    a.z_end_mm,
                    o.name,
                    b.z_start_mm,
                    b.z_end_mm,
                    g.core.as_deref().unwrap_or(""),
                    g.pillar.unwrap_or(0),
                    if gap < 0.0 {
                        format!("and overlap by {:.3} mm", -gap)
                    } else {
                        format!("only {gap:.3} mm apart")
                    },
                    intervals_words(&free)
                ),
            ));
        }
    }
    Ok(())
}

/// The reference fiber runs up the axis through the core's top hole.
fn check_top_hole(d: &Design, m: &Module) -> Result<(), SpecError> {
    let has_reference = m
        .gratings
        .iter()
        .any(|g| g.role == GratingRole::TemperatureReference);
    let need = d.fiber_routing.min_passage_mm(&d.printer);
    if has_reference && m.top_hole_diameter_mm < need - 1e-12 {
        return Err(err(
            "module.top_hole_diameter_mm",
            format!(
                "{} mm does not pass the reference fiber: at least {}",
                m.top_hole_diameter_mm,
                d.fiber_routing.min_passage_words(&d.printer)
            ),
        ));
    }
    Ok(())
}

/// `what` reaching up to `z` stays a printable wall below `over` at `limit`.
fn below(
    min_wall: f64,
    field: &str,
    what: &str,
    (z, limit): (f64, f64),
    over: &str,
) -> Result<(), SpecError> {
    if z + min_wall > limit {
        Err(err(
            field,
            format!(
                "{what} reaches {z:.3} mm, within a printable wall ({min_wall} mm) of {over} at {limit:.3} mm"
            ),
        ))
    } else {
        Ok(())
    }
}

/// The fibers bend out below the pillars, and the insert's and the cap's slots stay
/// below the features over them.
fn check_slots(p: &ModuleProfile, pp: &PartsProfile, min_wall: f64) -> Result<(), SpecError> {
    let z_b = pp.bend_start_z_mm;
    if z_b + min_wall > p.pillar_top_mm {
        return Err(err(
            "fiber_routing.min_bend_radius_mm",
            format!(
                "the fibers bend out below {z_b:.3} mm, which leaves no pillar below the pillar top at {:.3} mm; {BEND_ADVICE}",
                p.pillar_top_mm
            ),
        ));
    }
    below(
        min_wall,
        "fiber_routing.min_bend_radius_mm",
        "the slot for the reference fiber in the insert's base",
        (pp.insert_slot_top_mm, p.insert_junction_z_mm),
        "the insert's dome",
    )?;
    below(
        min_wall,
        "fiber_routing.min_bend_radius_mm",
        "the cap's fiber slots",
        (pp.cap_slot_top_mm, pp.pillar_bottom_mm),
        "the pillar bottoms",
    )
}

/// The cap's slots stay below the snap bead's lead-in, and the snap strains the cap's
/// material less than it permits.
fn check_snap(
    d: &Design,
    m: &Module,
    p: &ModuleProfile,
    pp: &PartsProfile,
) -> Result<(), SpecError> {
    let (Some(s), Some(sp)) = (&m.snap, &pp.snap) else {
        return Ok(());
    };
    below(
        d.printer.min_wall_mm,
        "module.snap.bead_height_mm",
        "the cap's fiber slots",
        (pp.cap_slot_top_mm, sp.lead_in_z_mm),
        "the snap bead's lead-in",
    )?;
    let Some(r) = snap_report(d, p, pp) else {
        return Ok(());
    };
    if r.cap_strain_percent <= r.permissible_strain_percent {
        return Ok(());
    }
    let allowed = if r.max_undercut_mm >= r.min_undercut_mm {
        format!(
            "allowed {:.4} to {:.4} mm",
            r.min_undercut_mm, r.max_undercut_mm
        )
    } else {
        format!(
            "no undercut fits: the printer needs at least {:.4} mm and the material allows at most {:.4} mm; remove [module.snap] (a sliding fit held by the fixture), thin module.cap_wall_mm or use a cap material that permits more strain",
            r.min_undercut_mm, r.max_undercut_mm
        )
    };
    Err(err(
        "module.snap.undercut_mm",
        format!(
            "{} mm strains the cap's ring by {:.3} % ({}), more than its material `{}` permits ({} %); {allowed}",
            s.undercut_mm,
            r.cap_strain_percent,
            r.strain_model,
            m.cap_material,
            r.permissible_strain_percent,
        ),
    ))
}

/// The reference grating's chamber fits the insert: above the slot the reference fiber
/// bends out through, with printable walls around it; and the grating starts above
/// the bend (checked with the other gratings).
fn check_reference_chamber(
    m: &Module,
    p: &ModuleProfile,
    pp: &PartsProfile,
    c: &ReferenceChamber,
    min_wall: f64,
) -> Result<(), SpecError> {
    let i = c.grating;
    let g = &m.gratings[i];
    if m.inserts.is_empty() {
        return Ok(());
    }
    if c.radius_mm + min_wall > p.insert_radius_mm {
        return Err(err(
            "fiber_routing.channel_clearance_mm",
            format!(
                "the reference grating's chamber (radius {:.3} mm, twice the bore's) leaves the insert (radius {:.3} mm) no printable wall",
                c.radius_mm, p.insert_radius_mm
            ),
        ));
    }
    let floor = pp.insert_slot_top_mm + min_wall;
    if c.span.chamber_bottom_z_mm < floor {
        return Err(err(
            &format!("module.gratings[{i}].length_mm"),
            format!(
                "reference grating `{}` ({} mm, with {} mm of fiber past it) hangs so low that its chamber (floor at {:.3} mm) meets the insert's slot for the fiber's exit (roof at {:.3} mm, + min wall {min_wall} mm); shorten the grating or its tail (module.gratings[{i}].tail_mm)",
                g.name,
                g.length_mm,
                g.tail_mm(),
                c.span.chamber_bottom_z_mm,
                pp.insert_slot_top_mm
            ),
        ));
    }
    Ok(())
}

/// One rule of a module's derived profile, evaluated: how far the design is past its
/// limit. Validation turns the first violated rule into an error; the optimiser adds
/// every rule's excess to its penalty, so the two can never disagree on a rule.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    /// Stable rule name (`radial_stack`, `pillar_spacing`, ...).
    pub rule: &'static str,
    /// The spec field an error names.
    pub field: String,
    /// What the rule requires, in words with units.
    pub requirement: String,
    /// How far past the limit, normalised by a length of the design (> 0: violated).
    pub excess: f64,
    /// What the design has, in words with units (the error message).
    pub detail: String,
}

impl Violation {
    /// Whether the design breaks this rule.
    pub fn violated(&self) -> bool {
        self.excess > 0.0
    }
}

/// Every rule on the module's derived profile, in validation order, with its excess.
pub fn profile_violations(m: &Module, min_wall: f64) -> Vec<Violation> {
    let prof = ModuleProfile::from_module_unchecked(m);
    vec![
        radial_stack(m, &prof),
        pillar_spacing(m, &prof, min_wall),
        top_hole(m, &prof),
        apex_flat(m, &prof),
        insert_radius(&prof, min_wall),
        cylinder_height(m, &prof, min_wall),
        grating_heights(m, &prof),
    ]
}

/// Each strain grating lies wholly on the cylindrical part of its pillar; the excess is
/// the worst grating's distance outside its allowed centre range over its length.
fn grating_heights(m: &Module, prof: &ModuleProfile) -> Violation {
    let mut worst = Violation {
        rule: "grating_heights",
        field: "module.gratings".into(),
        requirement: "each strain grating on the cylindrical part of its pillar".into(),
        excess: f64::NEG_INFINITY,
        detail: "every grating on its pillar's cylinder".into(),
    };
    for (i, g) in m.gratings.iter().enumerate() {
        let (GratingRole::Strain, Some(z)) = (g.role, g.center_height_mm) else {
            continue;
        };
        let lo = g.length_mm / 2.0;
        let hi = prof.pillar_top_mm - g.length_mm / 2.0;
        let excess = if z.is_finite() {
            (lo - z).max(z - hi) / g.length_mm.max(1e-9)
        } else {
            f64::INFINITY
        };
        // The error names the first grating out of range; the excess is the worst.
        if excess > 0.0 && !worst.violated() {
            worst.field = format!("module.gratings[{i}].center_height_mm");
            worst.detail = match range(&worst.field, z, lo, hi) {
                Err(e) => e.message,
                Ok(()) => format!("{z} mm lies in {lo:.4} to {hi:.4}"),
            };
        }
        worst.excess = worst.excess.max(excess);
    }
    worst
}

/// The walls, clearance and pillars leave the core at least a quarter of the outer
/// radius (and no wall is thicker than that quarter).
fn radial_stack(m: &Module, prof: &ModuleProfile) -> Violation {
    let r = m.outer_diameter_mm / 2.0;
    let thickest = m.cap_wall_mm.max(m.core_wall_mm);
    let core = prof.core_inner_radius_mm;
    Violation {
        rule: "radial_stack",
        field: "module.cap_wall_mm".into(),
        requirement: "walls ≤ R/4 and core inner radius ≥ R/4".into(),
        excess: ((thickest - 0.25 * r) / r).max((0.25 * r - core) / r),
        detail: format!(
            "walls, clearance and pillars ({:.3} mm in all) leave the core an inner radius of {core:.3} mm; at least a quarter of the outer radius ({:.3} mm) is needed: reduce the walls or the pillar height",
            r - core,
            0.25 * r
        ),
    }
}

/// Pillars must not overlap: their width at the core wall plus a gap of one minimum
/// wall between neighbours fits in 0.8 of the pitch.
fn pillar_spacing(m: &Module, prof: &ModuleProfile, min_wall: f64) -> Violation {
    let pl = &m.pillars;
    let pitch = std::f64::consts::TAU * prof.core_outer_radius_mm / pl.count as f64;
    Violation {
        rule: "pillar_spacing",
        field: "module.pillars.width_mm".into(),
        requirement: "pillar width + min wall ≤ 0.8 × pillar pitch".into(),
        excess: (pl.width_mm + min_wall - 0.8 * pitch) / pitch.abs().max(1e-9),
        detail: {
            let hi = pitch * 0.8 - min_wall;
            let lo = pl.groove_width_mm + 2.0 * min_wall;
            let conflict = if lo > hi {
                format!(" — below the {lo:.3} mm a pillar needs for its groove between walls (module.pillars.groove_width_mm + 2 × printer.min_wall_mm): no width fits these two rules; use fewer pillars (module.pillars.count), a larger module.outer_diameter_mm or a narrower groove")
            } else {
                String::new()
            };
            format!(
                "{} pillars of {:.3} mm overlap on a core wall of radius {:.3} mm (pillar width + min wall ≤ 0.8 × the pitch); allowed up to {hi:.3} mm each{conflict}",
                pl.count, pl.width_mm, prof.core_outer_radius_mm
            )
        },
    }
}

/// The reference fiber's hole stays well inside the core's dome.
fn top_hole(m: &Module, prof: &ModuleProfile) -> Violation {
    let limit = prof.core_dome_inner_sphere_radius_mm * 0.5;
    Violation {
        rule: "top_hole",
        field: "module.top_hole_diameter_mm".into(),
        requirement: "top hole radius < half the core's inner dome radius".into(),
        excess: hold_below(m.top_hole_diameter_mm / 2.0, limit),
        detail: format!(
            "allowed up to {:.3} mm (the core's inner dome radius)",
            prof.core_dome_inner_sphere_radius_mm
        ),
    }
}

/// The contact flat stays well inside the insert's dome.
fn apex_flat(m: &Module, prof: &ModuleProfile) -> Violation {
    let limit = prof.insert_sphere_radius_mm * 0.5;
    Violation {
        rule: "apex_flat",
        field: "module.apex_flat_diameter_mm".into(),
        requirement: "apex flat radius < half the insert's dome radius".into(),
        excess: hold_below(m.apex_flat_diameter_mm / 2.0, limit),
        detail: format!("allowed up to {:.3} mm", prof.insert_sphere_radius_mm),
    }
}

/// The insert keeps at least a printable radius.
fn insert_radius(prof: &ModuleProfile, min_wall: f64) -> Violation {
    Violation {
        rule: "insert_radius",
        field: "module.core_insert_clearance_mm".into(),
        requirement: format!("insert radius ≥ {min_wall} mm"),
        excess: (min_wall - prof.insert_radius_mm) / min_wall,
        detail: format!(
            "leaves the insert a radius of {:.3} mm",
            prof.insert_radius_mm
        ),
    }
}

/// The cylindrical section below the dome holds two walls (at least 1 mm each).
fn cylinder_height(m: &Module, prof: &ModuleProfile, min_wall: f64) -> Violation {
    let need = 2.0 * min_wall.max(1.0);
    Violation {
        rule: "cylinder_height",
        field: "module.overall_height_mm".into(),
        requirement: format!("cylindrical section ≥ {need:.3} mm"),
        excess: (need - prof.pillar_top_mm) / need,
        detail: format!(
            "{:.3} mm leaves a cylindrical section of {:.3} mm below the dome; make the module taller or the dome lower",
            m.overall_height_mm, prof.pillar_top_mm
        ),
    }
}

/// Excess of `value` over a strict upper `limit`, relative to the limit; a value on
/// the limit counts as past it (the rule is strict).
fn hold_below(value: f64, limit: f64) -> f64 {
    let excess = (value - limit) / limit.abs().max(1e-9);
    if value >= limit {
        excess.max(f64::MIN_POSITIVE)
    } else {
        excess
    }
}

/// The module's constraints on its derived profile: the first violated rule.
fn check_profile(m: &Module, min_wall: f64) -> Result<(), SpecError> {
    match profile_violations(m, min_wall)
        .into_iter()
        .find(Violation::violated)
    {
        Some(v) => Err(err(&v.field, v.detail)),
        None => Ok(()),
    }
}

/// The folder of shipped designs: `designs/` under the working directory, else the
/// repository's (two floors above this crate's manifest).
pub fn designs_dir() -> PathBuf {
    let local = PathBuf::from("designs");
    if local.is_dir() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../designs")
    }
}

/// Every `*.toml` in `dir`, sorted by file name: the design files a folder holds.
pub fn design_files(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    use anyhow::Context;
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read the designs folder {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    Ok(paths)
}

/// Every `*.toml` in `dir` ([`design_files`]), loaded and validated, sorted by file name.
pub fn load_designs(dir: &Path) -> anyhow::Result<Vec<(PathBuf, Design)>> {
    design_files(dir)?
        .into_iter()
        .map(|p| {
            let d = load(&p)?;
            Ok((p, d))
        })
        .collect()
}
