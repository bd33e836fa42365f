//! Checks on `[array]`: the sheet, the casting mold and its slits, the fibers'
//! positions and the gratings.

use super::rules::{free_intervals, intervals_words, positive, range, unique_name};
use crate::spec::error::{err, SpecError};
use crate::spec::{
    derived_slit_depth_mm, mold_slot_width_mm, seat_z_mm, ArrayGrating, Design, TactileArray,
    GRATING_END_GAP_MM,
};

impl Design {
    /// Check an array: the sheet, its mold, the fibers' positions and the gratings.
    pub(super) fn validate_array(&self, a: &TactileArray) -> Result<(), SpecError> {
        self.validate_sheet(a)?;
        self.validate_mold(a)?;
        self.validate_fiber_positions(a)?;
        for (i, g) in a.gratings.iter().enumerate() {
            unique_name(
                a.gratings[..i].iter().map(|o| o.name.as_str()),
                &g.name,
                &format!("array.gratings[{i}].name"),
                "grating",
            )?;
            Self::validate_array_grating(a, i, g)?;
            Self::validate_array_grating_spacing(a, i, g)?;
        }
        if a.gratings.is_empty() {
            return Err(err("array.gratings", "list at least one grating"));
        }
        if let Some(k) = a.max_loads {
            if !(1..=64).contains(&k) {
                return Err(err(
                    "array.max_loads",
                    format!("must be 1 to 64 simultaneous loads, got {k}"),
                ));
            }
        }
        Ok(())
    }

    /// The sheet: size, thickness (the coated fiber fits in it), cells, material, load
    /// limit, at least one fiber.
    fn validate_sheet(&self, a: &TactileArray) -> Result<(), SpecError> {
        positive("array.size_x_mm", a.size_x_mm, 1.0, 2000.0)?;
        positive("array.size_y_mm", a.size_y_mm, 1.0, 2000.0)?;
        positive("array.thickness_mm", a.thickness_mm, 0.2, 100.0)?;
        if self.fiber_routing.coated_diameter_mm >= a.thickness_mm {
            return Err(err(
                "array.thickness_mm",
                format!(
                    "{} mm does not hold the {} mm coated fiber (fiber_routing.coated_diameter_mm) at mid-thickness; allowed above {} mm",
                    a.thickness_mm,
                    self.fiber_routing.coated_diameter_mm,
                    self.fiber_routing.coated_diameter_mm
                ),
            ));
        }
        if a.cells_x == 0 || a.cells_x > 64 {
            return Err(err(
                "array.cells_x",
                format!("expected 1 to 64, got {}", a.cells_x),
            ));
        }
        if a.cells_y == 0 || a.cells_y > 64 {
            return Err(err(
                "array.cells_y",
                format!("expected 1 to 64, got {}", a.cells_y),
            ));
        }
        self.material(&a.material, "array.material")?;
        positive("array.ulimit_g", a.ulimit_g, 1e-3, 1e6)?;
        if a.fiber_x_mm.is_empty() {
            return Err(err("array.fiber_x_mm", "list at least one fiber"));
        }
        self.validate_sheet_model(a)
    }

    /// What the sheet model reads besides the sheet: the fibers' depth (the coated
    /// fiber inside the sheet), the table interface and the indenter.
    fn validate_sheet_model(&self, a: &TactileArray) -> Result<(), SpecError> {
        if let Some(d) = a.fiber_depth_mm {
            let r = self.fiber_routing.coated_diameter_mm / 2.0;
            if !(d.is_finite() && d > r && d < a.thickness_mm - r) {
                return Err(err(
                    "array.fiber_depth_mm",
                    format!(
                        "{d} mm does not keep the {} mm coated fiber inside the {} mm sheet; expected more than {r} mm and less than {} mm",
                        self.fiber_routing.coated_diameter_mm,
                        a.thickness_mm,
                        a.thickness_mm - r
                    ),
                ));
            }
        }
        if let Some(crate::spec::BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: k,
        }) = a.base
        {
            positive("array.base.tangential_stiffness_n_per_mm3", k, 1e-9, 1e6)?;
        }
        if let Some(d) = a.indenter_diameter_mm {
            positive(
                "array.indenter_diameter_mm",
                d,
                0.1,
                a.size_x_mm.min(a.size_y_mm),
            )?;
        }
        Ok(())
    }

    /// The casting mold: printable walls, a cavity that holds the sheet, and slits that
    /// hold the coated fiber at its depth in the sheet.
    fn validate_mold(&self, a: &TactileArray) -> Result<(), SpecError> {
        let mold = &a.mold;
        if let Some(pm) = &mold.print_material {
            self.material(pm, "array.mold.print_material")?;
        }
        positive("array.mold.internal_x_mm", mold.internal_x_mm, 1.0, 3000.0)?;
        positive("array.mold.internal_y_mm", mold.internal_y_mm, 1.0, 3000.0)?;
        range(
            "array.mold.wall_thickness_mm",
            mold.wall_thickness_mm,
            self.printer.min_wall_mm,
            50.0,
        )?;
        range(
            "array.mold.base_thickness_mm",
            mold.base_thickness_mm,
            self.printer.min_wall_mm,
            50.0,
        )?;
        positive("array.mold.wall_height_mm", mold.wall_height_mm, 0.2, 200.0)?;
        if mold.wall_height_mm < a.thickness_mm {
            return Err(err(
                "array.mold.wall_height_mm",
                format!(
                    "{} mm is lower than the sheet thickness {} mm",
                    mold.wall_height_mm, a.thickness_mm
                ),
            ));
        }
        self.validate_mold_slits(a)?;
        if a.size_x_mm > mold.internal_x_mm {
            return Err(err(
                "array.mold.internal_x_mm",
                format!(
                    "{} mm does not hold the {} mm sheet",
                    mold.internal_x_mm, a.size_x_mm
                ),
            ));
        }
        if a.size_y_mm > mold.internal_y_mm {
            return Err(err(
                "array.mold.internal_y_mm",
                format!(
                    "{} mm does not hold the {} mm sheet",
                    mold.internal_y_mm, a.size_y_mm
                ),
            ));
        }
        Ok(())
    }

    /// The mold's slits: as wide as the coated fiber and its clearance need, and as deep
    /// as puts the fiber at its depth (mid-thickness by default).
    fn validate_mold_slits(&self, a: &TactileArray) -> Result<(), SpecError> {
        let mold = &a.mold;
        // The slit's depth follows from the stack (base, sheet, fiber): its bottom, the
        // fiber's seat, lies above the cavity floor for every sheet thicker than the
        // fiber, so the base below it is the wall it needs. A stated depth must be the
        // derived one (checked below); no range of its own, so an error never names
        // a depth the user did not write.
        finite_stated("array.mold.slit_depth_mm", mold.slit_depth_mm)?;
        range(
            "array.mold.slit_width_mm",
            mold.slit_width_mm,
            self.printer.resolution_mm,
            5.0,
        )?;
        // The slit holds the coated fiber with its clearance and stays open in print.
        let need = self.fiber_routing.channel_width_mm(&self.printer);
        if mold.slit_width_mm < need - 1e-9 {
            return Err(err(
                "array.mold.slit_width_mm",
                format!(
                    "{} mm is narrower than the {need:.3} mm the fiber needs (coated diameter {} mm + 2 × clearance {} mm, at least the printer's floor of {}); allowed {need:.3} to 5 mm; leave the field out to derive it",
                    mold.slit_width_mm,
                    self.fiber_routing.coated_diameter_mm,
                    self.fiber_routing.channel_clearance_mm,
                    self.fiber_routing.min_passage_words(&self.printer)
                ),
            ));
        }
        let coated = self.fiber_routing.coated_diameter_mm;
        self.validate_seat_above_floor(a)?;
        let depth = derived_slit_depth_mm(a, coated, &self.printer);
        if (mold.slit_depth_mm - depth).abs() > 1e-6 {
            return Err(err(
                "array.mold.slit_depth_mm",
                format!(
                    "{} mm does not put the fiber at its depth of {} mm; expected {depth:.4} mm (down to the layer boundary of {} mm nearest base + fiber depth − coated diameter/2); leave the field out to derive it",
                    mold.slit_depth_mm,
                    a.fiber_depth(),
                    self.printer.layer_height_mm()
                ),
            ));
        }
        if mold.plugs {
            // The plug fills the pocket from the layer at or above the fiber's top to
            // the wall top: it must be a printable block.
            let seat = seat_z_mm(a, coated, &self.printer);
            let ledge = self.printer.layer_at_or_above_mm(seat + coated);
            let top = mold.base_thickness_mm + mold.wall_height_mm;
            let need = self.printer.min_wall_mm.max(self.printer.layer_height_mm());
            if top - ledge < need - 1e-9 {
                return Err(err(
                    "array.mold.wall_height_mm",
                    format!(
                        "{} mm leaves the slit's plug {:.3} mm high above the fiber, less than the printable {need} mm; raise the walls to at least {:.3} mm or set array.mold.plugs = false",
                        mold.wall_height_mm,
                        (top - ledge).max(0.0),
                        ledge + need - mold.base_thickness_mm
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The fiber's seat (its depth less its radius, on the nearest layer boundary) lies
    /// at least a layer above the cavity floor: a seat on the floor would open the
    /// slit into the cavity along its whole bottom (no wall under the fiber, and no
    /// closed solid). The error names the sheet's thickness (or the fiber's depth when
    /// stated) with the least that keeps the seat a layer up.
    fn validate_seat_above_floor(&self, a: &TactileArray) -> Result<(), SpecError> {
        let p = &self.printer;
        let (base, h) = (a.mold.base_thickness_mm, p.layer_height_mm());
        let rf = self.fiber_routing.coated_diameter_mm / 2.0;
        let seat = seat_z_mm(a, 2.0 * rf, p);
        // The lowest layer boundary above the floor, and the least depth whose seat
        // rounds to it (a slicer rounds to the nearest boundary).
        let first_up = ((base / h) + 1e-6).floor() * h + h;
        if seat >= first_up - 1e-9 {
            return Ok(());
        }
        let least_depth = first_up - h / 2.0 - base + rf;
        let (field, value, least) = match a.fiber_depth_mm {
            Some(d) => ("array.fiber_depth_mm", d, least_depth),
            None => ("array.thickness_mm", a.thickness_mm, 2.0 * least_depth),
        };
        Err(err(
            field,
            format!(
                "{value} mm puts the fiber's seat ({seat:.3} mm, its axis less its radius {rf} mm on the nearest {h} mm layer) on the cavity floor ({base} mm): the slit would open into the cavity under the fiber; allowed above {least:.4} mm (the seat one layer up, at {first_up:.3} mm)",
            ),
        ))
    }

    /// The fibers lie on the sheet, with a printable wall between neighbouring slits
    /// (or plug pockets).
    fn validate_fiber_positions(&self, a: &TactileArray) -> Result<(), SpecError> {
        let mold = &a.mold;
        let half_x = a.size_x_mm / 2.0;
        let mut xs: Vec<f64> = Vec::with_capacity(a.fiber_x_mm.len());
        for (i, &x) in a.fiber_x_mm.iter().enumerate() {
            let field = format!("array.fiber_x_mm[{i}]");
            range(&field, x, -half_x, half_x)?;
            xs.push(x);
        }
        xs.sort_by(|a, b| a.total_cmp(b));
        let min_gap = mold_slot_width_mm(self, mold) + self.printer.min_wall_mm;
        for w in xs.windows(2) {
            if w[1] - w[0] < min_gap {
                return Err(err(
                    "array.fiber_x_mm",
                    format!(
                        "fibers at {} mm and {} mm are closer than slit width + min wall = {min_gap:.3} mm",
                        w[0], w[1]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// One array grating (index `i`): on a listed fiber, on the sheet, a plausible
    /// wavelength and length.
    fn validate_array_grating(
        a: &TactileArray,
        i: usize,
        g: &ArrayGrating,
    ) -> Result<(), SpecError> {
        let f = |s: &str| format!("array.gratings[{i}].{s}");
        if g.fiber as usize >= a.fiber_x_mm.len() {
            return Err(err(
                &f("fiber"),
                format!("expected 0 to {}, got {}", a.fiber_x_mm.len() - 1, g.fiber),
            ));
        }
        range(&f("y_mm"), g.y_mm, -a.size_y_mm / 2.0, a.size_y_mm / 2.0)?;
        range(
            &f("bragg_wavelength_nm"),
            g.bragg_wavelength_nm,
            400.0,
            2000.0,
        )?;
        positive(&f("length_mm"), g.length_mm, 0.1, 50.0)?;
        Ok(())
    }
}

impl Design {
    /// Grating `i` keeps [`GRATING_END_GAP_MM`] of fiber from every earlier grating on
    /// its fiber; the error gives the centre positions that would.
    fn validate_array_grating_spacing(
        a: &TactileArray,
        i: usize,
        g: &ArrayGrating,
    ) -> Result<(), SpecError> {
        let others: Vec<(usize, &ArrayGrating)> = a.gratings[..i]
            .iter()
            .enumerate()
            .filter(|(_, o)| o.fiber == g.fiber)
            .collect();
        let keep = |o: &ArrayGrating| (g.length_mm + o.length_mm) / 2.0 + GRATING_END_GAP_MM;
        let Some((j, o)) = others
            .iter()
            .find(|(_, o)| (g.y_mm - o.y_mm).abs() < keep(o) - 1e-9)
        else {
            return Ok(());
        };
        let half_sheet = a.size_y_mm / 2.0;
        let blocked: Vec<(f64, f64)> = others
            .iter()
            .map(|(_, o)| (o.y_mm - keep(o), o.y_mm + keep(o)))
            .collect();
        let free = free_intervals(-half_sheet, half_sheet, &blocked);
        Err(err(
            &format!("array.gratings[{i}].y_mm"),
            format!(
                "grating `{}` ({} mm long at {} mm) overlaps grating `{}` (array.gratings[{j}], {} mm long at {} mm) on fiber {}: two gratings on one fiber keep {GRATING_END_GAP_MM} mm of fiber between their ends; allowed {} (on the sheet, clear of the fiber's other gratings)",
                g.name,
                g.length_mm,
                g.y_mm,
                o.name,
                o.length_mm,
                o.y_mm,
                g.fiber,
                intervals_words(&free)
            ),
        ))
    }
}

/// A field derived when left out must, when stated, be a finite number.
fn finite_stated(field: &str, v: f64) -> Result<(), SpecError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(err(field, format!("expected a finite number, got {v}")))
    }
}
