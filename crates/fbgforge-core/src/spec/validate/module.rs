//! Checks on `[module]`: the shell and contact overrides, the pillars, the snap-fit,
//! cores and inserts (known materials, distinct names) and the gratings.

use super::rules::{finite, positive, range, unique_name};
use crate::spec::error::{err, SpecError};
use crate::spec::{Design, GratingRole, Module, ModuleGrating, Snap};

/// Smallest snap undercut per unit of the printer's resolution: the crest and the
/// pillar faces may each print half a resolution off, so an undercut of 1.5 × the
/// resolution keeps at least half a resolution of catch in the worst case.
pub const MIN_UNDERCUT_PER_RESOLUTION: f64 = 1.5;

impl Design {
    /// Check a module: its shell, pillars, snap-fit, cores, inserts and gratings.
    pub(super) fn validate_module(&self, m: &Module) -> Result<(), SpecError> {
        self.validate_module_shell(m)?;
        self.validate_pillars(m)?;
        let r = m.outer_diameter_mm / 2.0;
        positive(
            "module.top_hole_diameter_mm",
            m.top_hole_diameter_mm,
            0.1,
            0.5 * r,
        )?;
        positive(
            "module.apex_flat_diameter_mm",
            m.apex_flat_diameter_mm,
            0.01,
            0.5 * r,
        )?;
        if let Some(snap) = &m.snap {
            self.validate_snap(m, snap)?;
        }
        self.validate_cores_and_inserts(m)?;
        for (i, g) in m.gratings.iter().enumerate() {
            unique_name(
                m.gratings[..i].iter().map(|o| o.name.as_str()),
                &g.name,
                &format!("module.gratings[{i}].name"),
                "grating",
            )?;
            Self::validate_module_grating(m, i, g)?;
        }
        Ok(())
    }

    /// The module's outer size, walls, clearances, cap material and contact overrides.
    fn validate_module_shell(&self, m: &Module) -> Result<(), SpecError> {
        let min_wall = self.printer.min_wall_mm;
        positive("module.outer_diameter_mm", m.outer_diameter_mm, 4.0, 200.0)?;
        let r = m.outer_diameter_mm / 2.0;
        positive("module.overall_height_mm", m.overall_height_mm, 2.0, 500.0)?;
        range("module.dome_height_mm", m.dome_height_mm, 0.1 * r, r)?;
        range("module.cap_wall_mm", m.cap_wall_mm, min_wall, 0.25 * r)?;
        range("module.core_wall_mm", m.core_wall_mm, min_wall, 0.25 * r)?;
        self.fit_clearance("module.cap_core_clearance_mm", m.cap_core_clearance_mm)?;
        self.fit_clearance(
            "module.core_insert_clearance_mm",
            m.core_insert_clearance_mm,
        )?;
        self.material(&m.cap_material, "module.cap_material")?;
        if let Some(f) = m.interrogator_rate_hz {
            positive("module.interrogator_rate_hz", f, 1e-3, 1e7)?;
        }
        if let Some(l) = &m.limits {
            positive("module.limits.max_force_n", l.max_force_n, 1e-6, 1e5)?;
            positive(
                "module.limits.max_grating_strain_microstrain",
                l.max_grating_strain_microstrain,
                1.0,
                1e5,
            )?;
        }
        self.validate_contact(m)
    }

    /// `[module.contact]`: each length stated once (relative or in mm), each ratio and
    /// each resolved length in its range.
    fn validate_contact(&self, m: &Module) -> Result<(), SpecError> {
        let c = &m.contact;
        let r = m.outer_diameter_mm / 2.0;
        for (relative, absolute, rel_name, abs_name) in [
            (
                c.clip_height_to_cap_wall,
                c.clip_height_mm,
                "clip_height_to_cap_wall",
                "clip_height_mm",
            ),
            (
                c.dome_clearance_to_fit_clearance,
                c.dome_clearance_mm,
                "dome_clearance_to_fit_clearance",
                "dome_clearance_mm",
            ),
            (
                c.dome_contact_radius_to_patch,
                c.dome_contact_radius_mm,
                "dome_contact_radius_to_patch",
                "dome_contact_radius_mm",
            ),
        ] {
            if relative.is_some() && absolute.is_some() {
                return Err(err(
                    &format!("module.contact.{abs_name}"),
                    format!(
                        "give either `{rel_name}` (relative, scales with the module) or `{abs_name}` (at this size), not both"
                    ),
                ));
            }
        }
        if let Some(k) = c.clip_height_to_cap_wall {
            positive("module.contact.clip_height_to_cap_wall", k, 1e-3, 100.0)?;
        }
        if let Some(k) = c.dome_clearance_to_fit_clearance {
            range(
                "module.contact.dome_clearance_to_fit_clearance",
                k,
                0.0,
                100.0,
            )?;
        }
        if let Some(k) = c.dome_contact_radius_to_patch {
            positive(
                "module.contact.dome_contact_radius_to_patch",
                k,
                1e-3,
                100.0,
            )?;
        }
        // The lengths they resolve to, for the fields the design states (the defaults
        // follow features that are checked themselves).
        let field = |rel: Option<f64>, rel_name: &str, abs_name: &str| {
            if rel.is_some() {
                format!("module.contact.{rel_name}")
            } else {
                format!("module.contact.{abs_name}")
            }
        };
        if c.clip_height_to_cap_wall.is_some() || c.clip_height_mm.is_some() {
            positive(
                &field(
                    c.clip_height_to_cap_wall,
                    "clip_height_to_cap_wall",
                    "clip_height_mm",
                ),
                m.clip_height_mm(),
                1e-3,
                m.overall_height_mm,
            )?;
        }
        if c.dome_clearance_to_fit_clearance.is_some() || c.dome_clearance_mm.is_some() {
            self.fit_clearance(
                &field(
                    c.dome_clearance_to_fit_clearance,
                    "dome_clearance_to_fit_clearance",
                    "dome_clearance_mm",
                ),
                m.dome_clearance_mm(),
            )?;
        }
        if c.dome_contact_radius_to_patch.is_some() || c.dome_contact_radius_mm.is_some() {
            positive(
                &field(
                    c.dome_contact_radius_to_patch,
                    "dome_contact_radius_to_patch",
                    "dome_contact_radius_mm",
                ),
                m.dome_contact_radius_mm(),
                1e-3,
                0.5 * r,
            )?;
        }
        Ok(())
    }

    /// A fit clearance: 0 (a press fit) or at least the printer's resolution (a gap
    /// narrower than the printer resolves prints closed or not at all), at most 2 mm.
    fn fit_clearance(&self, field: &str, c: f64) -> Result<(), SpecError> {
        range(field, c, 0.0, 2.0)?;
        let res = self.printer.resolution_mm;
        if c > 0.0 && c < res - 1e-12 {
            return Err(err(
                field,
                format!(
                    "{c} mm is a gap the printer cannot make (resolution {res} mm): use 0 for a press fit or at least {res} mm"
                ),
            ));
        }
        Ok(())
    }

    /// The pillars: count, then their size (first, so a pillar too small for its
    /// groove and hole is named as such), the groove, and the fiber hole: at least the
    /// fiber plus the printer's resolution, at most what leaves printable walls.
    fn validate_pillars(&self, m: &Module) -> Result<(), SpecError> {
        let min_wall = self.printer.min_wall_mm;
        let r = m.outer_diameter_mm / 2.0;
        let pl = &m.pillars;
        if !(3..=8).contains(&pl.count) {
            return Err(err(
                "module.pillars.count",
                format!("expected 3 to 8 pillars, got {}", pl.count),
            ));
        }
        finite(
            "module.pillars.first_pillar_angle_deg",
            pl.first_pillar_angle_deg,
        )?;
        positive(
            "module.pillars.groove_depth_mm",
            pl.groove_depth_mm,
            0.05,
            5.0,
        )?;
        positive(
            "module.pillars.groove_width_mm",
            pl.groove_width_mm,
            0.1,
            10.0,
        )?;
        let coated = self.fiber_routing.coated_diameter_mm;
        let passage = self.fiber_routing.min_passage_mm(&self.printer);
        positive(
            "module.pillars.fiber_hole_diameter_mm",
            pl.fiber_hole_diameter_mm,
            0.13,
            5.0,
        )?;
        // The pillar must hold the narrowest passable hole between two printable walls,
        // radially below its groove and tangentially, and the groove between walls;
        // it may be at most 0.3 R high and leave the core an inner radius of R/4
        // (the radial stack, checked again on the profile). Each field gets one range
        // with both ends; when they cross, both rules are named.
        let min_height = pl.groove_depth_mm + passage + 2.0 * min_wall;
        let stack_height = 0.75 * r - m.cap_wall_mm - m.cap_core_clearance_mm - m.core_wall_mm;
        let (max_height, max_rule) = if stack_height < 0.3 * r {
            (
                stack_height,
                format!("the radial stack: 3/4 of the outer radius ({:.3} mm) less module.cap_wall_mm, module.cap_core_clearance_mm and module.core_wall_mm, so the core keeps an inner radius of R/4", 0.75 * r),
            )
        } else {
            (
                0.3 * r,
                format!("0.3 × the outer radius {r} mm (module.outer_diameter_mm)"),
            )
        };
        let min_rule = format!(
            "module.pillars.groove_depth_mm {} mm + the smallest fiber hole {passage:.3} mm + 2 × printer.min_wall_mm {min_wall} mm",
            pl.groove_depth_mm
        );
        sized(
            "module.pillars.height_mm",
            pl.height_mm,
            (min_height, &min_rule),
            (max_height, &max_rule),
        )?;
        let min_width = pl.groove_width_mm.max(passage) + 2.0 * min_wall;
        sized(
            "module.pillars.width_mm",
            pl.width_mm,
            (
                min_width,
                &format!(
                    "the wider of module.pillars.groove_width_mm {} mm and the smallest fiber hole {passage:.3} mm, + 2 × printer.min_wall_mm {min_wall} mm",
                    pl.groove_width_mm
                ),
            ),
            (r, &format!("the outer radius {r} mm")),
        )?;
        // The cap's alignment pillar is the groove less a clearance on each side.
        if pl.groove_width_mm - 2.0 * m.cap_core_clearance_mm < min_wall {
            return Err(err(
                "module.pillars.groove_width_mm",
                format!(
                    "the cap's alignment pillar (groove width − 2 × clearance = {:.3} mm) is thinner than the printer minimum {min_wall} mm; allowed from {:.3} mm",
                    pl.groove_width_mm - 2.0 * m.cap_core_clearance_mm,
                    min_wall + 2.0 * m.cap_core_clearance_mm
                ),
            ));
        }
        // The minimum passage: the fiber plus what the printer resolves.
        if pl.fiber_hole_diameter_mm < passage - 1e-12 {
            return Err(err(
                "module.pillars.fiber_hole_diameter_mm",
                format!(
                    "{} mm does not pass the {coated} mm coated fiber: a fiber passage needs at least {}",
                    pl.fiber_hole_diameter_mm,
                    self.fiber_routing.min_passage_words(&self.printer)
                ),
            ));
        }
        // The fiber hole sits between the core wall and the groove bottom; both bounds
        // are at least the passage once the pillar's size has passed.
        let max_hole_radial = pl.height_mm - pl.groove_depth_mm - 2.0 * min_wall;
        let max_hole_tangential = pl.width_mm - 2.0 * min_wall;
        let max_hole = max_hole_radial.min(max_hole_tangential);
        if pl.fiber_hole_diameter_mm > max_hole {
            return Err(err(
                "module.pillars.fiber_hole_diameter_mm",
                format!(
                    "{} mm is wider than its pillar allows; allowed {passage:.3} to {max_hole:.3} mm (pillar height − groove depth − 2 × min wall = {max_hole_radial:.3}, pillar width − 2 × min wall = {max_hole_tangential:.3})",
                    pl.fiber_hole_diameter_mm
                ),
            ));
        }
        Ok(())
    }

    /// At least one core; cores and inserts of known materials and distinct names.
    fn validate_cores_and_inserts(&self, m: &Module) -> Result<(), SpecError> {
        if m.cores.is_empty() {
            return Err(err("module.cores", "list at least one core"));
        }
        for (i, c) in m.cores.iter().enumerate() {
            self.material(&c.material, &format!("module.cores[{i}].material"))?;
            unique_name(
                m.cores[..i].iter().map(|o| o.name.as_str()),
                &c.name,
                &format!("module.cores[{i}].name"),
                "core",
            )?;
        }
        for (i, ins) in m.inserts.iter().enumerate() {
            self.material(&ins.material, &format!("module.inserts[{i}].material"))?;
            unique_name(
                m.inserts[..i].iter().map(|o| o.name.as_str()),
                &ins.name,
                &format!("module.inserts[{i}].name"),
                "insert",
            )?;
        }
        Ok(())
    }

    /// One module grating (index `i`): wavelength, length, core, and what its role
    /// needs (a strain grating its core, pillar and height; a reference none).
    fn validate_module_grating(m: &Module, i: usize, g: &ModuleGrating) -> Result<(), SpecError> {
        let pl = &m.pillars;
        let f = |s: &str| format!("module.gratings[{i}].{s}");
        range(
            &f("bragg_wavelength_nm"),
            g.bragg_wavelength_nm,
            400.0,
            2000.0,
        )?;
        positive(&f("length_mm"), g.length_mm, 0.1, 50.0)?;
        if let Some(core) = &g.core {
            if !m.cores.iter().any(|c| &c.name == core) {
                return Err(err(&f("core"), format!("no core named `{core}`")));
            }
        }
        match g.role {
            GratingRole::Strain => {
                if g.core.is_none() {
                    return Err(err(
                        &f("core"),
                        "a strain grating needs the core it is bonded in",
                    ));
                }
                let pillar = g
                    .pillar
                    .ok_or_else(|| err(&f("pillar"), "a strain grating needs its pillar index"))?;
                if pillar >= pl.count {
                    return Err(err(
                        &f("pillar"),
                        format!("expected 0 to {}, got {pillar}", pl.count - 1),
                    ));
                }
                // Its range along the pillar needs the derived profile:
                // checked in crate::design.
                g.center_height_mm.ok_or_else(|| {
                    err(
                        &f("center_height_mm"),
                        "a strain grating needs its centre height",
                    )
                })?;
                if g.tail_mm.is_some() {
                    return Err(err(
                        &f("tail_mm"),
                        "the tail past the grating is a reference grating's; a strain grating's fiber ends in its hole",
                    ));
                }
            }
            GratingRole::TemperatureReference => {
                if g.pillar.is_some() || g.center_height_mm.is_some() {
                    return Err(err(
                        &f("pillar"),
                        "a temperature-reference grating hangs free on the module's axis: give it no pillar or centre height",
                    ));
                }
                if let Some(t) = g.tail_mm {
                    positive(&f("tail_mm"), t, 0.5, 50.0)?;
                }
            }
        }
        Ok(())
    }

    /// The snap-fit: a printable bead, a lead-in that does not jam, and a cap material
    /// with a permissible strain to size it by.
    fn validate_snap(&self, m: &Module, s: &Snap) -> Result<(), SpecError> {
        let res = self.printer.resolution_mm;
        // Each of the two mating surfaces (the bead's crest, the pillar faces) prints
        // within half the resolution of where it is drawn, so an undercut y may print
        // as y − res; at least half the resolution must be left to catch.
        let min_undercut = MIN_UNDERCUT_PER_RESOLUTION * res;
        // (1e-9 mm of slack: 1.5 × 0.05 is 0.07500000000000001 in floating point.)
        positive(
            "module.snap.undercut_mm",
            s.undercut_mm,
            min_undercut - 1e-9,
            m.pillars.groove_depth_mm.max(min_undercut),
        )?;
        positive("module.snap.bead_height_mm", s.bead_height_mm, res, 20.0)?;
        range(
            "module.snap.friction_coefficient",
            s.friction_coefficient,
            0.0,
            1.5,
        )?;
        range(
            "module.snap.lead_in_angle_deg",
            s.lead_in_angle_deg,
            5.0,
            80.0,
        )?;
        range(
            "module.snap.retention_angle_deg",
            s.retention_angle_deg,
            5.0,
            90.0,
        )?;
        // A lead-in steeper than the friction angle's complement jams: the joint
        // could not be pushed together at any force.
        let jam = s.friction_coefficient * s.lead_in_angle_deg.to_radians().tan();
        if jam >= 1.0 {
            return Err(err(
                "module.snap.lead_in_angle_deg",
                format!(
                    "{}° with friction {} jams (μ·tan α = {jam:.3} ≥ 1); allowed below {:.1}°",
                    s.lead_in_angle_deg,
                    s.friction_coefficient,
                    (1.0 / s.friction_coefficient.max(1e-9)).atan().to_degrees()
                ),
            ));
        }
        let cap = self.material(&m.cap_material, "module.cap_material")?;
        if cap.permissible_strain_percent.is_none() {
            return Err(err(
                &format!("materials.{}.permissible_strain_percent", m.cap_material),
                "the cap's material needs a permissible strain (percent) to size the snap-fit",
            ));
        }
        Ok(())
    }
}

/// A size bounded below by what it must hold and above by what the rest of the design
/// leaves it: one message with both ends, and when they cross, both rules named (a user
/// never meets two messages whose ranges cannot both be met).
fn sized(
    field: &str,
    v: f64,
    (lo, lo_rule): (f64, &str),
    (hi, hi_rule): (f64, &str),
) -> Result<(), SpecError> {
    finite(field, v)?;
    if lo > hi + 1e-12 {
        return Err(err(
            field,
            format!(
                "{v} mm: no value fits, two rules conflict: at least {lo:.4} mm ({lo_rule}) and at most {hi:.4} mm ({hi_rule}); change the fields those rules name"
            ),
        ));
    }
    if v <= 0.0 || v < lo - 1e-12 || v > hi + 1e-12 {
        let (bound, rule) = if v < lo {
            ("at least", lo_rule)
        } else {
            ("at most", hi_rule)
        };
        return Err(err(
            field,
            format!("{v} mm is out of range; allowed {lo:.4} to {hi:.4} mm ({bound}: {rule})"),
        ));
    }
    Ok(())
}
