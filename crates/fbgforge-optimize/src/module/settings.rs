//! What a module optimisation maximises and everything it needs besides the design
//! (limits, band, variables, choices, solvers, budget, seed), with the checks it
//! cannot run without.

use super::variables::Variable;
use crate::materials::MaterialLibrary;
use crate::prediction::Robustness;
use crate::quality::QualitySettings;
use crate::solvers::{RunSettings, SolverKind};
use serde::Serialize;

/// What to maximise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Objective {
    /// Q = |K|·R²/Δt_max of the worst strain grating, pm/(N·s).
    Q,
    /// |K| of the worst strain grating, pm/N.
    Sensitivity,
    /// The force range, N: the largest force before a grating reaches the strain limit
    /// or leaves its wavelength window (the Pareto front's other end).
    #[serde(rename = "force-range")]
    ForceRange,
}

impl Objective {
    /// Parse `q` or `sensitivity`.
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        match s {
            "q" => Ok(Objective::Q),
            "sensitivity" => Ok(Objective::Sensitivity),
            "force-range" => Ok(Objective::ForceRange),
            _ => anyhow::bail!("unknown objective `{s}`; expected q, sensitivity or force-range"),
        }
    }

    /// Unit of the objective value.
    pub fn unit(self) -> &'static str {
        match self {
            Objective::Q => "pm/(N·s)",
            Objective::Sensitivity => "pm/N",
            Objective::ForceRange => "N",
        }
    }

    /// The scalar objective's name for reports (`Q`, `|K|`, `force range`).
    pub fn symbol(self) -> &'static str {
        match self {
            Objective::Q => "Q",
            Objective::Sensitivity => "|K|",
            Objective::ForceRange => "force range",
        }
    }
}

/// Which design of the Pareto front is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preference {
    /// The knee: the front's design farthest beyond the chord between its most
    /// sensitive and its widest-range designs, in sensitivity and force range on log
    /// scales normalised over the front (the table's best when no design lies clearly
    /// beyond it).
    Knee,
    /// The best of the table by the scalar objective (`--objective`).
    Objective,
    /// The largest sensitivity.
    Sensitivity,
    /// The widest force range.
    ForceRange,
    /// The shortest lag Δt_max.
    Lag,
    /// The largest R².
    RSquared,
}

impl Preference {
    /// Every preference, in the order of `--prefer`'s help.
    pub const ALL: [Preference; 6] = [
        Preference::Knee,
        Preference::Objective,
        Preference::Sensitivity,
        Preference::ForceRange,
        Preference::Lag,
        Preference::RSquared,
    ];

    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Preference::Knee => "knee",
            Preference::Objective => "objective",
            Preference::Sensitivity => "sensitivity",
            Preference::ForceRange => "force-range",
            Preference::Lag => "lag",
            Preference::RSquared => "r-squared",
        }
    }

    /// Parse a name, listing the known ones when it is unknown.
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        Preference::ALL
            .iter()
            .copied()
            .find(|p| p.name() == s)
            .ok_or_else(|| {
                let known: Vec<&str> = Preference::ALL.iter().map(|p| p.name()).collect();
                anyhow::anyhow!(
                    "unknown ModuleSettings.prefer `{s}`; expected one of {}",
                    known.join(", ")
                )
            })
    }
}

/// Everything the module optimisation needs besides the design.
#[derive(Debug, Clone, Serialize)]
pub struct ModuleSettings {
    /// What to maximise.
    pub objective: Objective,
    /// The user's largest force, N: strain and window constraints are checked there.
    pub max_force_n: f64,
    /// Largest allowed |axial strain| of a grating at the largest force.
    pub max_grating_strain: f64,
    /// Share of the strain limit every grating keeps free at the far end of its design
    /// interval (the written design is held to (1 − this) × the limit there).
    pub strain_margin_fraction: f64,
    /// Smallest printable fit clearance, mm (default: the printer's resolution).
    pub min_fit_clearance_mm: Option<f64>,
    /// Temperature excursion each window must also hold, ± K.
    pub temperature_span_k: f64,
    /// Gap kept between neighbouring gratings' ranges, nm.
    pub guard_band_nm: f64,
    /// Interrogator band, nm (SM125: 1510–1590 nm).
    pub band_nm: (f64, f64),
    /// Variables searched.
    pub vary: Vec<Variable>,
    /// User bounds replacing the defaults.
    pub bounds: Vec<(Variable, f64, f64)>,
    /// Core materials tried (None: the design's plus the library's for this printer).
    pub cores: Option<Vec<String>>,
    /// Insert materials tried; `none` is the hollow core (None: the design's plus the
    /// library's, plus hollow).
    pub inserts: Option<Vec<String>>,
    /// Q model settings.
    pub quality: QualitySettings,
    /// Solvers compared.
    pub solvers: Vec<SolverKind>,
    /// Random starts besides the design's own point.
    pub extra_starts: usize,
    /// Budget of each run.
    pub run: RunSettings,
    /// Seed for the starts and the swarms.
    pub seed: u64,
    /// How a design is scored over the model's uncertainty about K (the contact
    /// window); the bounding readings' constraint applies in every case.
    pub robustness: Robustness,
    /// Interrogator sample rate, Hz: Δt_max's floor is one sample period. `None`: the
    /// design's `interrogator_rate_hz` (2 Hz when absent), or a measured prototype's.
    pub rate_hz: Option<f64>,
    /// Which design of the Pareto front is written.
    pub prefer: Preference,
    /// What to do with a design that fails one of the paper's statements (`predict`'s
    /// check on the design as written): by default it is not written while another
    /// design of the front meets them all.
    pub paper_statements: PaperStatementsPolicy,
    /// Force levels the Pareto front is searched at between `max_force_n` and the
    /// widest force range a choice reaches (evenly spaced; each a search for the best
    /// objective with the strain and wavelength limits held at that force).
    pub front_levels: usize,
}

impl Default for ModuleSettings {
    fn default() -> Self {
        ModuleSettings {
            objective: Objective::Q,
            max_force_n: 20.0,
            max_grating_strain: 3e-3,
            strain_margin_fraction: crate::prediction::STRAIN_MARGIN_FRACTION,
            min_fit_clearance_mm: None,
            temperature_span_k: 10.0,
            guard_band_nm: 0.2,
            band_nm: (1510.0, 1590.0),
            vary: Variable::DEFAULT.to_vec(),
            bounds: Vec::new(),
            cores: None,
            inserts: None,
            quality: QualitySettings::default(),
            solvers: SolverKind::BOTH.to_vec(),
            extra_starts: 2,
            run: RunSettings::default(),
            seed: 2024,
            robustness: Robustness::WorstCase,
            rate_hz: None,
            prefer: Preference::Knee,
            paper_statements: PaperStatementsPolicy::Exclude,
            front_levels: 3,
        }
    }
}

impl ModuleSettings {
    /// The strain the limits are held to: the limit less the required margin.
    pub fn held_strain_limit(&self) -> f64 {
        (1.0 - self.strain_margin_fraction) * self.max_grating_strain
    }

    /// Check the numbers a front end gives before anything is loaded: the solvers'
    /// iteration limits and the smallest fit clearance ([`check_settings`] checks the
    /// rest against the material library).
    pub fn check(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.run.max_iters > 0 && self.run.swarm_iters > 0,
            "RunSettings.max_iters and RunSettings.swarm_iters must be at least 1"
        );
        if let Some(c) = self.min_fit_clearance_mm {
            anyhow::ensure!(
                c.is_finite() && c > 0.0,
                "ModuleSettings.min_fit_clearance_mm must be a positive number of mm, got {c}"
            );
        }
        Ok(())
    }
}

/// Check the settings an optimisation cannot run without.
pub(super) fn check_settings(
    lib: &MaterialLibrary,
    settings: &ModuleSettings,
) -> anyhow::Result<()> {
    anyhow::ensure!(!lib.materials.is_empty(), "the material library is empty");
    anyhow::ensure!(
        settings.max_force_n.is_finite() && settings.max_force_n > 0.0,
        "ModuleSettings.max_force_n must be a positive number of newtons, got {}",
        settings.max_force_n
    );
    anyhow::ensure!(
        settings.max_grating_strain.is_finite() && settings.max_grating_strain > 0.0,
        "the grating strain limit must be positive, got {}",
        settings.max_grating_strain
    );
    anyhow::ensure!(
        (0.0..1.0).contains(&settings.strain_margin_fraction),
        "ModuleSettings.strain_margin_fraction must keep part of the strain limit: at least 0 and below all of it, got {:.1} % of it",
        100.0 * settings.strain_margin_fraction
    );
    anyhow::ensure!(!settings.solvers.is_empty(), "no solver selected");
    if let Some(f) = settings.rate_hz {
        anyhow::ensure!(
            f.is_finite() && f > 0.0,
            "ModuleSettings.rate_hz must be a positive number of hertz, got {f}"
        );
    }
    Ok(())
}

/// What `optimize` does with a design that fails one of the paper's statements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PaperStatementsPolicy {
    /// Never write it while a design of the front meets every statement (default); if
    /// none does, the preferred design is written and names what it fails.
    Exclude,
    /// Write the preferred design whatever it fails, naming what it fails in the JSON,
    /// the table and the written file's description.
    Report,
}

impl PaperStatementsPolicy {
    /// Parse `exclude` or `report`.
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        match s {
            "exclude" => Ok(PaperStatementsPolicy::Exclude),
            "report" => Ok(PaperStatementsPolicy::Report),
            _ => anyhow::bail!(
                "unknown ModuleSettings.paper_statements `{s}`; expected exclude or report"
            ),
        }
    }
}
