//! The modelling choices of a finite-element solve of the module: mesh density, how
//! cap, core and insert touch ([`InsertContact`], [`DomeContact`], [`PillarCoupling`],
//! or one [`ContactReading`] for all three), extrapolation and the linear solver.

use crate::fem::element::Formulation;
use crate::fem::linear::{EnvelopeCholesky, LinearSolver, SparseLlt};
use crate::model::LoadCase;
use crate::spec::CylinderCoupling;

/// How the insert meets the core's inner wall (Case I).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InsertContact {
    /// Bonded over the whole interface (no sliding anywhere).
    Bonded,
    /// Bonded on the dome, frictionless (radial tie only) along the cylinder.
    SlidingWall,
}

/// Whether the cap's dome presses on the core's dome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DomeContact {
    /// The printed gap stays open: the force passes through the pillars only.
    Gap,
    /// Facing dome nodes tied over the whole dome (cap and core touch everywhere).
    Tied,
    /// Facing dome nodes tied within the apex contact patch only: the apex flat widened
    /// through half the cap wall, radius = apex flat radius + cap wall / 2 (the same
    /// patch as the closed form's direct path). Default.
    ApexPatch,
    /// Unilateral contact across the printed clearance: every facing pair of dome nodes
    /// may touch and push but never pull, and touches only once its gap has closed
    /// (`fem::contact`). The contact zone grows with the force.
    Unilateral,
}

/// How the pillars couple cap and core along the cylinder.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PillarCoupling {
    /// Pillar rings bonded to cap and core over their whole length (the paper's "no
    /// sliding between CC and PSC"). Default.
    Bonded,
    /// The cap slides axially over the core's pillars (radial contact only) and is
    /// bonded to them only in a clip band at the base, one cap wall high: the load
    /// path the closed form assumes (cap and core in series through the base clip).
    BaseClip,
    /// Bonded in the clip band at the base; above it cap and core meet in unilateral,
    /// frictionless contact across the printed radial clearance (`fem::contact`): they
    /// may push each other apart but not pull, and touch only once the gap has closed.
    BaseClipContact,
}

/// A reading of how cap and core touch and are held together: the contact choices of
/// [`FemOptions`] that the model policy (`crate::prediction`) solves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactReading {
    /// The design's `[module.contact]`: cylinders sliding above the base clip (or
    /// bonded); in Case I the domes bear on each other within the design's contact
    /// radius, in Case II over the whole dome (no insert holds the hollow core's dome
    /// up, so the cap's dome presses all of it). The nominal prediction.
    Design,
    /// Pillars bonded to cap and core along their length, domes tied over the apex
    /// patch (the paper's literal "no sliding"): the most tightly coupled reading,
    /// lower end of Case I's band.
    BondedPillars,
    /// Cylinders sliding above the base clip, the domes touching over the apex patch
    /// only: the least coupled reading with the domes in contact, upper end of Case I's
    /// band.
    SlidingApexPatch,
    /// Cylinders as the design says (sliding: unilateral contact across the printed
    /// radial clearance above the clip), domes in unilateral contact across the printed
    /// dome clearance: the contact zone grows with the force, so K depends on F.
    Unilateral,
    /// The design's reading with the domes' contact radius at the low end of the
    /// window that meets the paper's statements (`Contact::PAPER_WINDOW_TO_PATCH`,
    /// 1.30 × the apex patch): one end of a Case I row's design interval.
    WindowLow,
    /// The same at the high end of the window (1.48 × the apex patch).
    WindowHigh,
}

impl ContactReading {
    /// Short description for tables and reports.
    pub fn describe(self, m: &crate::spec::Module, case: LoadCase) -> String {
        let clip = m.clip_height_mm();
        let cyl = match m.contact.cylinders {
            CylinderCoupling::Sliding => {
                format!("cylinders sliding above a {clip:.2} mm base clip")
            }
            CylinderCoupling::Bonded => "pillars bonded to the cap".to_string(),
        };
        match self {
            ContactReading::Design if case == LoadCase::II => {
                format!("{cyl}, domes in contact over the whole dome (Case II)")
            }
            ContactReading::Design => format!(
                "{cyl}, domes in contact within r = {:.3} mm",
                m.dome_contact_radius_mm()
            ),
            ContactReading::BondedPillars => format!(
                "pillars bonded to the cap, domes tied over the apex patch (r = {:.3} mm)",
                m.apex_patch_radius_mm()
            ),
            ContactReading::SlidingApexPatch => format!(
                "cylinders sliding above a {clip:.2} mm base clip, domes touching over the apex patch only (r = {:.3} mm)",
                m.apex_patch_radius_mm()
            ),
            ContactReading::Unilateral => format!(
                "{cyl}, unilateral contact across the printed {:.3} mm dome clearance",
                m.dome_clearance_mm()
            ),
            ContactReading::WindowLow | ContactReading::WindowHigh => format!(
                "{cyl}, domes in contact within r = {:.3} mm (the {} end of the contact window)",
                self.window_radius_mm(m).unwrap_or(f64::NAN),
                if self == ContactReading::WindowLow {
                    "low"
                } else {
                    "high"
                }
            ),
        }
    }

    /// The domes' contact radius of a window reading, mm (`None` for the others).
    pub fn window_radius_mm(self, m: &crate::spec::Module) -> Option<f64> {
        let (lo, hi) = crate::spec::Contact::PAPER_WINDOW_TO_PATCH;
        match self {
            ContactReading::WindowLow => Some(lo * m.apex_patch_radius_mm()),
            ContactReading::WindowHigh => Some(hi * m.apex_patch_radius_mm()),
            _ => None,
        }
    }
}

/// Mesh density and modelling choices of a finite-element solve.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FemOptions {
    /// Target element size along the cylinders (and radially in the insert), mm.
    pub element_size_mm: f64,
    /// Target element size along the domes' meridian, mm. The domes carry the load by
    /// bending and membrane action near the apex contact and decide how the force is
    /// shared, so they need finer elements than the cylinders' smooth far field.
    pub dome_element_size_mm: f64,
    /// Elements through the thinner of the cap and core walls (thinner layers get
    /// at least one).
    pub elements_through_wall: usize,
    /// Insert/core contact in Case I.
    pub insert_contact: InsertContact,
    /// Cap/core dome contact.
    pub dome_contact: DomeContact,
    /// Cap/core coupling along the pillars.
    pub pillar_coupling: PillarCoupling,
    /// Radius of the zone around the apex over which the domes bear on each other with
    /// [`DomeContact::ApexPatch`] (measured on the core's outer dome), mm; `None`: the
    /// apex contact patch, apex flat radius + cap wall / 2.
    #[serde(default)]
    pub dome_contact_radius_mm: Option<f64>,
    /// Height of the clip band at the base where cap and core are bonded when the
    /// pillars are not ([`PillarCoupling::BaseClip`], [`PillarCoupling::BaseClipContact`]),
    /// mm; `None`: one cap wall.
    #[serde(default)]
    pub clip_height_mm: Option<f64>,
    /// Mixed (locking-free) or plain displacement elements.
    #[serde(skip, default = "default_formulation")]
    pub formulation: Formulation,
    /// Linear solver.
    pub solver: SolverKind,
    /// When set, also solve a mesh twice as coarse and extrapolate each grating's
    /// strain as ε_h + (ε_h − ε_2h) / (2^p − 1) with this order p (Richardson). The
    /// apex-patch tie of Case I converges at a low order (0.5 to 1.2 measured), so
    /// p = 1 removes most of the discretisation error for a 15 % longer solve.
    #[serde(default)]
    pub richardson_order: Option<f64>,
    /// The module diameter at which the element sizes hold as given, mm: a module of
    /// diameter D is meshed with every size times D / this, so every size gets the
    /// mesh (and the relative accuracy) the reference size has; `None`: the sizes are
    /// absolute. The policy's meshes ([`FemOptions::default`], [`FemOptions::mesh_level`])
    /// are relative to the paper's 34 mm module (docs/fem.md §5.3).
    #[serde(default)]
    pub reference_diameter_mm: Option<f64>,
    /// Further radii on the core's outer dome that carry a mesh station, mm: the
    /// radii of the other contact readings of the same module, so that every reading
    /// meshes alike and readings that differ only in their contact radius share one
    /// factorisation (`fem::solve_configurations`).
    #[serde(default)]
    pub dome_station_radii_mm: [Option<f64>; 4],
}

/// Which linear solver factorises the stiffness matrix (`crate::fem::linear`; timed
/// against each other by the criterion bench `benches/fem.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolverKind {
    /// [`SparseLlt`]: faer's sparse Cholesky with an AMD ordering (default: fastest
    /// in the bench).
    Faer,
    /// [`EnvelopeCholesky`]: hand-written envelope Cholesky after RCM.
    Envelope,
}

impl SolverKind {
    /// The solver behind the name.
    pub fn solver(self) -> &'static dyn LinearSolver {
        match self {
            SolverKind::Faer => &SPARSE_LLT,
            SolverKind::Envelope => &EnvelopeCholesky,
        }
    }
}

static SPARSE_LLT: SparseLlt = SparseLlt {
    kernel: crate::fem::linear::LltKernel::Supernodal,
};

fn default_formulation() -> Formulation {
    Formulation::MixedQ9P1
}

impl Default for FemOptions {
    /// The policy's mesh: level 1 relative to the 34 mm module, with two-level
    /// Richardson extrapolation (order 1) from level 0 ([`FemOptions::mesh_level`]).
    fn default() -> Self {
        FemOptions::mesh_level(FemOptions::DEFAULT_MESH_LEVEL)
    }
}

impl FemOptions {
    /// The policy's default mesh level.
    pub const DEFAULT_MESH_LEVEL: u32 = 1;

    /// The coarsest mesh level a caller may ask the policy for: level 0's coarser
    /// partner keeps its one element through each wall, so its Richardson step
    /// understates its error (0.7–0.8 % stated at 10 mm where K_I lies 7.5 % from
    /// level 3; docs/fem.md §5.3), and a stated error must bound the error.
    pub const MIN_MESH_LEVEL: u32 = 1;

    /// The finest level the policy refines to by itself
    /// (`PredictionRequest.refine_to_level`): level 3 costs about 20× level 1 and
    /// brought every design of the model-error study within the stated accuracy
    /// (docs/fem.md §5.3); level 4 is left to a caller who asks for it.
    pub const AUTO_FINEST_MESH_LEVEL: u32 = 3;

    /// The finest mesh level a caller may ask the policy for (level 4 of the 34 mm
    /// module has about half a million unknowns in Case I).
    pub const MAX_MESH_LEVEL: u32 = 4;

    /// Diameter of the module the policy's element sizes are stated for, mm (the
    /// paper's).
    pub const REFERENCE_DIAMETER_MM: f64 = 34.0;

    /// The policy's mesh at level `k` (0 to [`FemOptions::MAX_MESH_LEVEL`]): the sizes
    /// of [`FemOptions::level`] on the 34 mm module, scaled with the module's diameter,
    /// extrapolated (Richardson, order 1) with the level below; each level halves every
    /// size, and the step the extrapolation takes is the row's discretisation
    /// estimate (docs/fem.md §5.3).
    ///
    /// ```
    /// use fbgforge_model::fem::FemOptions;
    /// let o = FemOptions::mesh_level(2);
    /// assert_eq!(o.element_size_mm, 1.0);
    /// assert_eq!(o.richardson_order, Some(1.0));
    /// assert_eq!(FemOptions::default(), FemOptions::mesh_level(1));
    /// ```
    pub fn mesh_level(k: u32) -> Self {
        FemOptions {
            richardson_order: Some(1.0),
            reference_diameter_mm: Some(Self::REFERENCE_DIAMETER_MM),
            ..FemOptions::level(k)
        }
    }

    /// The mesh level of these options when they are a policy mesh
    /// ([`FemOptions::mesh_level`]), read back from the element size.
    pub fn policy_level(&self) -> Option<u32> {
        (0..=Self::MAX_MESH_LEVEL).find(|&k| {
            let o = FemOptions::mesh_level(k);
            o.element_size_mm == self.element_size_mm
                && o.dome_element_size_mm == self.dome_element_size_mm
                && self.reference_diameter_mm == o.reference_diameter_mm
        })
    }

    /// These options (solver, contact choices) on the policy's mesh of level `k`.
    ///
    /// ```
    /// use fbgforge_model::fem::FemOptions;
    /// let o = FemOptions::default().at_level(3);
    /// assert_eq!(o.policy_level(), Some(3));
    /// assert_eq!(o.solver, FemOptions::default().solver);
    /// ```
    pub fn at_level(&self, k: u32) -> Self {
        let m = FemOptions::mesh_level(k);
        FemOptions {
            element_size_mm: m.element_size_mm,
            dome_element_size_mm: m.dome_element_size_mm,
            elements_through_wall: m.elements_through_wall,
            reference_diameter_mm: m.reference_diameter_mm,
            richardson_order: m.richardson_order,
            ..*self
        }
    }

    /// The same options on a mesh twice as coarse (sizes doubled, half the elements
    /// through a wall, at least one), without extrapolation.
    pub fn coarsened(&self) -> Self {
        FemOptions {
            element_size_mm: 2.0 * self.element_size_mm,
            dome_element_size_mm: 2.0 * self.dome_element_size_mm,
            elements_through_wall: (self.elements_through_wall / 2).max(1),
            richardson_order: None,
            ..*self
        }
    }

    /// These options (mesh, solver) with the contact choices of `reading` for module `m`
    /// in `case`.
    pub fn with_reading(
        self,
        m: &crate::spec::Module,
        reading: ContactReading,
        case: LoadCase,
    ) -> Self {
        let sliding = m.contact.cylinders == CylinderCoupling::Sliding;
        let clip = Some(m.clip_height_mm());
        let design_coupling = if sliding {
            PillarCoupling::BaseClip
        } else {
            PillarCoupling::Bonded
        };
        let (pillar_coupling, dome_contact, radius) = match reading {
            ContactReading::WindowLow | ContactReading::WindowHigh => (
                design_coupling,
                if case == LoadCase::II {
                    DomeContact::Tied
                } else {
                    DomeContact::ApexPatch
                },
                reading.window_radius_mm(m),
            ),
            ContactReading::Design => (
                if sliding {
                    PillarCoupling::BaseClip
                } else {
                    PillarCoupling::Bonded
                },
                if case == LoadCase::II {
                    DomeContact::Tied
                } else {
                    DomeContact::ApexPatch
                },
                Some(m.dome_contact_radius_mm()),
            ),
            ContactReading::BondedPillars => (PillarCoupling::Bonded, DomeContact::ApexPatch, None),
            ContactReading::SlidingApexPatch => {
                (PillarCoupling::BaseClip, DomeContact::ApexPatch, None)
            }
            ContactReading::Unilateral => (
                if sliding {
                    PillarCoupling::BaseClipContact
                } else {
                    PillarCoupling::Bonded
                },
                DomeContact::Unilateral,
                None,
            ),
        };
        // Every tie reading of the module meshes alike: stations at the design's
        // contact radius and at the window's ends (the unilateral reading keeps its
        // own mesh: its pairs are every facing node).
        let dome_station_radii_mm = if reading == ContactReading::Unilateral {
            [None; 4]
        } else {
            reading_station_radii(m)
        };
        FemOptions {
            pillar_coupling,
            dome_contact,
            dome_contact_radius_mm: radius,
            clip_height_mm: clip,
            dome_station_radii_mm,
            ..self
        }
    }

    /// Refinement levels of the convergence study: level k has cylinder elements of
    /// 4 / 2^k mm, dome elements a quarter of that, and 2^k elements through a wall:
    /// every level halves every element size of the one before (level 1 = default).
    pub fn level(k: u32) -> Self {
        let h = 4.0 / 2f64.powi(k as i32);
        FemOptions {
            element_size_mm: h,
            dome_element_size_mm: h / 4.0,
            elements_through_wall: 1usize << k,
            insert_contact: InsertContact::SlidingWall,
            dome_contact: DomeContact::ApexPatch,
            pillar_coupling: PillarCoupling::Bonded,
            clip_height_mm: None,
            dome_contact_radius_mm: None,
            formulation: Formulation::MixedQ9P1,
            solver: SolverKind::Faer,
            richardson_order: None,
            reference_diameter_mm: None,
            dome_station_radii_mm: [None; 4],
        }
    }
}

/// The contact radii every tie reading of `m` carries a dome station at, mm: the apex
/// patch's, the design's, and the contact window's ends when the design rests on the
/// default radius (a calibrated radius has no window).
fn reading_station_radii(m: &crate::spec::Module) -> [Option<f64>; 4] {
    let patch = Some(m.apex_patch_radius_mm());
    let design = Some(m.dome_contact_radius_mm());
    if m.contact_radius_is_default() {
        [
            patch,
            design,
            ContactReading::WindowLow.window_radius_mm(m),
            ContactReading::WindowHigh.window_radius_mm(m),
        ]
    } else {
        [patch, design, None, None]
    }
}
