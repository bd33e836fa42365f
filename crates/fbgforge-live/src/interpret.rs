//! From a frame of peaks to what the sensor feels: cell loads of an array (every frame
//! reconstructed with the array's default method) or the temperature-compensated
//! force on each grating of a module (from the predicted or a calibrated K).
//!
//! Each grating is found in the frame by the windows `verify` uses (nominal ± half
//! the smallest spacing, at most 2.5 nm; the peak nearest the grating's previous
//! wavelength when two fall in one window). Shifts are taken from a tare: the mean
//! wavelength of each grating over the first frames, which the sensor must see
//! unloaded (a printed grating is rarely at its nominal wavelength to the picometre).

use super::source::Frame;
use super::tare::{Phase, Tare, TareChange, TareSettings, TareState};
use crate::array::kernel::matrix_from_design;
use crate::array::methods::{self, Method, NoisePrior, ReadingSettings, Reconstruction};
use crate::array::problem::{default_min_load_g, SensingProblem};
use crate::array::reconstruct::{prepare, MethodRequest, Setup, DEFAULT_BUDGET_US};
use crate::array::trust::FrameFlags;
use crate::logs::assign::{default_half_width_nm, GratingWindow, PeakTracker};
use crate::model::LoadCase;
use crate::prediction::{FidelityChoice, PredictionRequest};
use crate::spec::{Design, GratingRole};
use anyhow::{anyhow, bail, Context, Result};
use serde::Serialize;
use std::collections::BTreeMap;

/// How to interpret a stream.
#[derive(Debug, Clone)]
pub struct InterpretOptions {
    /// Frames the tare window holds at least (0: no tare, shifts from the design's
    /// nominal wavelengths); see [`crate::tare`].
    pub tare_frames: usize,
    /// Frame time the tare window spans at least, s.
    pub tare_s: f64,
    /// After the first full tare window, how long to wait for one at rest before
    /// refusing to read, s.
    pub tare_wait_s: f64,
    /// Half-width of each grating's window, nm (default: as `verify`).
    pub window_half_width_nm: Option<f64>,
    /// Module: the core plugged in (default: the first core of the design).
    pub core: Option<String>,
    /// Module: the load case (default: I with an insert, II without).
    pub case: Option<LoadCase>,
    /// Module: the insert in Case I.
    pub insert: Option<String>,
    /// Module: which model predicts K.
    pub fidelity: FidelityChoice,
    /// Module: calibrated K per grating, pm/N, replacing the prediction.
    pub calibrated_k_pm_per_n: BTreeMap<String, f64>,
    /// Array: the method (default: the library's default for the array).
    pub method: Option<String>,
    /// The interrogator's resolution, the noise standard deviation of a wavelength
    /// reading, pm (default: the paper's 0.5 pm): the tare judges rest against it, and
    /// for an array it sets the ℓ0 penalty of `support` and `bnb` as in `reconstruct`.
    pub resolution_pm: f64,
    /// Array: per-frame time budget of the default method choice, µs (default
    /// [`DEFAULT_BUDGET_US`]); ignored when a method is named.
    pub budget_us: f64,
}

impl InterpretOptions {
    /// Check the array's reading settings whatever the design (a module ignores them):
    /// a positive resolution and a positive per-frame budget.
    pub fn validate(&self) -> Result<()> {
        crate::array::methods::check_resolution(self.resolution_pm)
            .map_err(|e| anyhow!("InterpretOptions.resolution_pm: {e}"))?;
        crate::array::choice::check_budget(self.budget_us)
            .map_err(|e| anyhow!("InterpretOptions.budget_us: {e}"))?;
        self.tare_settings().validate()
    }

    /// The tare's settings.
    pub fn tare_settings(&self) -> TareSettings {
        TareSettings {
            frames: self.tare_frames,
            min_s: self.tare_s,
            wait_s: self.tare_wait_s,
            resolution_pm: self.resolution_pm,
        }
    }
}

impl Default for InterpretOptions {
    fn default() -> Self {
        InterpretOptions {
            tare_frames: 50,
            tare_s: 1.0,
            tare_wait_s: 30.0,
            window_half_width_nm: None,
            core: None,
            case: None,
            insert: None,
            fidelity: FidelityChoice::Auto,
            calibrated_k_pm_per_n: BTreeMap::new(),
            method: None,
            resolution_pm: NoisePrior::paper().resolution_pm,
            budget_us: DEFAULT_BUDGET_US,
        }
    }
}

/// Read calibrated K values from a `verify --json` report (`measurement.gratings[]`:
/// `grating`, `sensitivity_pm_per_n`).
pub fn calibration_from_verify_json(path: &std::path::Path) -> Result<BTreeMap<String, f64>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the calibration {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not JSON; expected a verification report (`report.json`)",
            path.display()
        )
    })?;
    let gratings = v
        .pointer("/measurement/gratings")
        .and_then(|g| g.as_array())
        .ok_or_else(|| {
            anyhow!(
                "{}: no `measurement.gratings` list; expected a verification report (`report.json`)",
                path.display()
            )
        })?;
    let mut out = BTreeMap::new();
    for g in gratings {
        let name = g.get("grating").and_then(|n| n.as_str());
        let k = g.get("sensitivity_pm_per_n").and_then(|k| k.as_f64());
        if let (Some(name), Some(k)) = (name, k) {
            if k.is_finite() && k != 0.0 {
                out.insert(name.to_string(), k);
            }
        }
    }
    if out.is_empty() {
        bail!(
            "{}: no grating with a finite, non-zero `sensitivity_pm_per_n`",
            path.display()
        );
    }
    Ok(out)
}

/// What one frame gave.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Reading {
    /// Array: load on each cell.
    Loads {
        /// Load per cell, g, in the order of [`Interpreter::outputs`].
        loads_g: Vec<f64>,
        /// Whether the method converged.
        converged: bool,
        /// ‖A x − y‖, pm.
        residual_pm: f64,
        /// Whether the answer is the proven optimum of the method's objective.
        certified: bool,
        /// Why the frame should not be trusted, as words (`inconsistent`, `ceiling`,
        /// …; empty when it can be): [`crate::array::trust`].
        flags: FrameFlags,
    },
    /// Module: force from each strain grating.
    Forces {
        /// Force per strain grating, N (None where its peak was missing).
        forces_n: Vec<Option<f64>>,
        /// Temperature change from the tare, K (None without a reference grating).
        delta_t_k: Option<f64>,
    },
}

/// A frame turned into shifts, ready for the (parallel) solve.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Shifts from the tare, pm, one per tracked grating (NaN: missing).
    pub shifts_pm: Vec<f64>,
    /// The sensor reads below its tare in this frame: every grating that carries load
    /// at or below it, one of them well below (5 σ), so the tare held a load (or, with
    /// no reference grating, the temperature fell). Not to be trusted.
    pub below_tare: bool,
}

/// Why a frame gave no reading.
#[derive(Debug, Clone, PartialEq)]
pub enum Skip {
    /// Taken into the tare window while waiting for rest.
    Tare,
    /// The tare was refused (the sensor never came to rest): nothing is read until
    /// a re-tare.
    Refused,
    /// Not usable: warning kind and message.
    Bad(&'static str, String),
}

/// One frame found in the peaks: each grating's wavelength and what became of it.
#[derive(Debug, Clone)]
pub struct Assigned {
    /// The frame's number (1 = the first frame the interpreter was given).
    pub frame: u64,
    /// Wavelength of each tracked grating, nm, in [`Interpreter::gratings`] order
    /// (NaN: no peak in its window).
    pub peaks_nm: Vec<f64>,
    /// Shifts to solve, or why there are none.
    pub result: Result<Prepared, Skip>,
    /// Whether a window held more than one peak.
    pub ambiguous: bool,
}

/// Frame-level test that the sensor reads below its tare: every load-bearing grating
/// at most 3 σ above it, one at least 5 σ below (σ that grating's noise).
const BELOW_FRAME: (f64, f64) = (3.0, 5.0);
/// The same test on a settled window's means, which are far less noisy: at most 1 σ
/// above, one at least 4 σ below.
const BELOW_WINDOW: (f64, f64) = (1.0, 4.0);

/// Whether load-direction shifts `d` (with their noise σ) are below the tare by the
/// test `(above, below)`: the grating furthest below and by how much, pm.
fn below(d: &[(f64, f64)], (above, under): (f64, f64)) -> Option<(usize, f64)> {
    let mut low: Option<(usize, f64)> = None;
    let mut any = false;
    for (i, &(v, sigma)) in d.iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        any = true;
        if v > above * sigma {
            return None;
        }
        if v <= -under * sigma && low.is_none_or(|(_, l)| v < l) {
            low = Some((i, v));
        }
    }
    low.filter(|_| any)
}

/// The array part: the method set up for the design's matrix.
struct ArrayPart {
    setup: Setup,
    cells_x: usize,
    cells_y: usize,
    ulimit_g: f64,
}

/// The module part: K per strain grating and the reference.
#[derive(Debug, Clone)]
struct ModulePart {
    /// Index (in the tracked gratings) of each strain grating and its K, pm/N.
    strain: Vec<(usize, f64)>,
    /// Index of the reference grating, if any.
    reference: Option<usize>,
    /// Temperature sensitivity of the reference, pm/K.
    reference_pm_per_k: f64,
    /// Last good reference shift, pm (held over a dropped reference peak).
    last_reference_shift_pm: Option<f64>,
}

/// Turns frames into readings for one design.
pub struct Interpreter {
    design_name: String,
    tracker: PeakTracker,
    tare: Tare,
    /// Frames given so far.
    frames: u64,
    /// Module: the core plugged in.
    core: Option<String>,
    /// Array: each cell's centre on the sheet, mm, in the order of the outputs.
    cell_centers_mm: Vec<(f64, f64)>,
    /// When the first frame was read: the clock of frames without a time of their own.
    clock_origin: Option<std::time::Instant>,
    nominal_nm: Vec<f64>,
    outputs: Vec<String>,
    array: Option<ArrayPart>,
    module: Option<ModulePart>,
    method: Option<Method>,
    description: String,
}

impl Interpreter {
    /// Prepare a design: windows, tare, and the array's reconstructor or the module's K.
    pub fn new(design: &Design, opts: &InterpretOptions) -> Result<Self> {
        match (&design.array, &design.module) {
            (Some(_), _) => Self::for_array(design, opts),
            (None, Some(_)) => Self::for_module(design, opts),
            (None, None) => bail!(
                "design `{}` has neither an [array] nor a [module] section",
                design.name
            ),
        }
    }

    fn windows(
        names: &[String],
        nominal: &[f64],
        opts: &InterpretOptions,
    ) -> Result<Vec<GratingWindow>> {
        let hw = match opts.window_half_width_nm {
            Some(w) if w.is_finite() && w > 0.0 => w,
            Some(w) => bail!("the window half-width must be a positive number of nm, got {w}"),
            None => default_half_width_nm(nominal),
        };
        if !(hw.is_finite() && hw > 0.0) {
            bail!("two gratings share a nominal wavelength: their peaks cannot be told apart");
        }
        Ok(names
            .iter()
            .zip(nominal)
            .map(|(n, &l)| GratingWindow::new(n, l, hw))
            .collect())
    }

    fn for_array(design: &Design, opts: &InterpretOptions) -> Result<Self> {
        let a = design.array.as_ref().expect("checked by the caller");
        let (matrix, ulimit_g) = matrix_from_design(design)?;
        let problem = SensingProblem::new(matrix.sensitivity_pm_per_g.clone(), ulimit_g, true)?
            .with_min_load_g(default_min_load_g(ulimit_g))?;
        let max_loads = a
            .max_loads
            .map(|k| k as usize)
            .unwrap_or(methods::DEFAULT_MAX_LOADS);
        let prior = ReadingSettings {
            max_loads,
            resolution_pm: opts.resolution_pm,
        };
        let request = match &opts.method {
            Some(m) => MethodRequest::named(Method::from_name(m)?),
            None => MethodRequest::Default {
                budget_us: opts.budget_us,
            },
        };
        // The same decision `reconstruct` and the Python binding make; the default
        // choice is probed on synthetic frames because no frame has arrived yet.
        let setup = prepare(&problem, &prior, &request, None)?;
        let method = setup.method;
        let names: Vec<String> = a.gratings.iter().map(|g| g.name.clone()).collect();
        let nominal: Vec<f64> = a.gratings.iter().map(|g| g.bragg_wavelength_nm).collect();
        let windows = Self::windows(&names, &nominal, opts)?;
        Ok(Interpreter {
            design_name: design.name.clone(),
            tare: Tare::new(opts.tare_settings(), names.clone(), nominal.clone()),
            frames: 0,
            core: None,
            cell_centers_mm: crate::profile::ArrayLayout::from_array(a).cell_centers_mm,
            clock_origin: None,
            tracker: PeakTracker::new(windows),
            nominal_nm: nominal,
            outputs: matrix.cells.clone(),
            array: Some(ArrayPart {
                setup,
                cells_x: a.cells_x as usize,
                cells_y: a.cells_y as usize,
                ulimit_g,
            }),
            module: None,
            method: Some(method),
            description: format!(
                "array {}×{} cells, {} gratings, method {} (resolution {} pm)",
                a.cells_x,
                a.cells_y,
                names.len(),
                method.name(),
                prior.resolution_pm
            ),
        })
    }

    /// The core plugged in: the one named (checked), else the design's first.
    fn module_core(design: &Design, opts: &InterpretOptions) -> Result<String> {
        let m = design.module.as_ref().expect("checked by the caller");
        match &opts.core {
            Some(c) => {
                if !m.cores.iter().any(|k| &k.name == c) {
                    let names: Vec<&str> = m.cores.iter().map(|k| k.name.as_str()).collect();
                    bail!(
                        "design `{}` has no core named `{c}`; its cores are: {}",
                        design.name,
                        names.join(", ")
                    );
                }
                Ok(c.clone())
            }
            None => m
                .cores
                .first()
                .map(|k| k.name.clone())
                .ok_or_else(|| anyhow!("design `{}` lists no core", design.name)),
        }
    }

    /// The load case (I with an insert, II without, unless named), checked against the
    /// insert given and the design's inserts.
    fn module_case(design: &Design, opts: &InterpretOptions) -> Result<LoadCase> {
        let m = design.module.as_ref().expect("checked by the caller");
        let case = opts.case.unwrap_or(if opts.insert.is_some() {
            LoadCase::I
        } else {
            LoadCase::II
        });
        if case == LoadCase::II && opts.insert.is_some() {
            bail!("InterpretOptions.insert names the insert of Case I; Case II has none");
        }
        let insert_names = || -> Vec<&str> { m.inserts.iter().map(|i| i.name.as_str()).collect() };
        if case == LoadCase::I && opts.insert.is_none() {
            let names = insert_names();
            bail!(
                "Case I needs InterpretOptions.insert; the design's inserts are: {}",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            );
        }
        if let Some(ins) = &opts.insert {
            if !m.inserts.iter().any(|i| &i.name == ins) {
                bail!(
                    "design `{}` has no insert named `{ins}`; its inserts are: {}",
                    design.name,
                    insert_names().join(", ")
                );
            }
        }
        Ok(case)
    }

    /// The core's strain gratings (at least one), with every calibrated K naming one.
    fn module_strain_gratings<'a>(
        design: &'a Design,
        core: &str,
        opts: &InterpretOptions,
    ) -> Result<Vec<&'a crate::spec::ModuleGrating>> {
        let m = design.module.as_ref().expect("checked by the caller");
        let strain: Vec<&crate::spec::ModuleGrating> = m
            .gratings
            .iter()
            .filter(|g| g.role == GratingRole::Strain && g.core.as_deref() == Some(core))
            .collect();
        if strain.is_empty() {
            bail!(
                "core `{core}` of design `{}` carries no strain grating",
                design.name
            );
        }
        for name in opts.calibrated_k_pm_per_n.keys() {
            if !strain.iter().any(|g| &g.name == name) {
                let names: Vec<&str> = strain.iter().map(|g| g.name.as_str()).collect();
                bail!(
                    "calibrated K for `{name}`, which is not a strain grating of core `{core}` (those are: {})",
                    names.join(", ")
                );
            }
        }
        Ok(strain)
    }

    /// The policy's K per strain grating of `core` in `case`, pm/N.
    fn predicted_k(
        design: &Design,
        core: &str,
        case: LoadCase,
        opts: &InterpretOptions,
    ) -> Result<BTreeMap<String, f64>> {
        let request = PredictionRequest {
            force_n: 1.0,
            case: Some(case),
            fidelity: opts.fidelity,
            ..PredictionRequest::default()
        };
        Ok(crate::prediction::predict(design, &request)
            .with_context(|| format!("design `{}`: cannot predict K", design.name))?
            .into_iter()
            .filter(|r| {
                r.detail.prediction.core == core && r.detail.prediction.insert == opts.insert
            })
            .map(|r| {
                (
                    r.detail.prediction.grating.clone(),
                    r.detail.prediction.sensitivity_pm_per_n,
                )
            })
            .collect())
    }

    /// K of each strain grating, pm/N: calibrated where given, else predicted; a K
    /// that reads no force is refused.
    fn strain_k(
        strain: &[&crate::spec::ModuleGrating],
        opts: &InterpretOptions,
        predicted: &BTreeMap<String, f64>,
    ) -> Result<Vec<f64>> {
        let mut ks = Vec::with_capacity(strain.len());
        for g in strain {
            let k = match opts.calibrated_k_pm_per_n.get(&g.name) {
                Some(&k) => k,
                None => *predicted
                    .get(&g.name)
                    .ok_or_else(|| anyhow!("the model gave no K for grating `{}`", g.name))?,
            };
            if !(k.is_finite() && k != 0.0) {
                bail!(
                    "K of grating `{}` is {k} pm/N: no force can be read from it",
                    g.name
                );
            }
            ks.push(k);
        }
        Ok(ks)
    }

    /// Prepare a module: its core and load case, K per strain grating, the reference.
    fn for_module(design: &Design, opts: &InterpretOptions) -> Result<Self> {
        let m = design.module.as_ref().expect("checked by the caller");
        let core = Self::module_core(design, opts)?;
        let case = Self::module_case(design, opts)?;
        let strain = Self::module_strain_gratings(design, &core, opts)?;
        // A reference named after this core first, else one bonded to no core.
        let reference = m
            .gratings
            .iter()
            .filter(|g| g.role == GratingRole::TemperatureReference)
            .find(|g| g.core.as_deref() == Some(core.as_str()))
            .or_else(|| {
                m.gratings
                    .iter()
                    .find(|g| g.role == GratingRole::TemperatureReference && g.core.is_none())
            });
        // Predicted K only where no calibration is given.
        let need_prediction = strain
            .iter()
            .any(|g| !opts.calibrated_k_pm_per_n.contains_key(&g.name));
        let predicted = if need_prediction {
            Self::predicted_k(design, &core, case, opts)?
        } else {
            BTreeMap::new()
        };
        let ks = Self::strain_k(&strain, opts, &predicted)?;
        let mut names: Vec<String> = strain.iter().map(|g| g.name.clone()).collect();
        let mut nominal: Vec<f64> = strain.iter().map(|g| g.bragg_wavelength_nm).collect();
        let outputs = names.clone();
        let reference_idx = reference.map(|r| {
            names.push(r.name.clone());
            nominal.push(r.bragg_wavelength_nm);
            names.len() - 1
        });
        let windows = Self::windows(&names, &nominal, opts)?;
        let reference_pm_per_k = reference
            .map(|r| {
                design
                    .fiber
                    .temperature_sensitivity_pm_per_k(r.bragg_wavelength_nm)
            })
            .unwrap_or(f64::NAN);
        let k_source = if opts.calibrated_k_pm_per_n.is_empty() {
            "predicted K"
        } else if need_prediction {
            "calibrated and predicted K"
        } else {
            "calibrated K"
        };
        Ok(Interpreter {
            design_name: design.name.clone(),
            tare: Tare::new(opts.tare_settings(), names.clone(), nominal.clone()),
            frames: 0,
            core: Some(core.clone()),
            cell_centers_mm: Vec::new(),
            clock_origin: None,
            tracker: PeakTracker::new(windows),
            nominal_nm: nominal,
            outputs,
            array: None,
            module: Some(ModulePart {
                strain: ks.into_iter().enumerate().collect(),
                reference: reference_idx,
                reference_pm_per_k,
                last_reference_shift_pm: None,
            }),
            method: None,
            description: format!(
                "module core {core}, Case {case}{}, {k_source}{}",
                opts.insert
                    .as_deref()
                    .map(|i| format!(" ({i})"))
                    .unwrap_or_default(),
                reference
                    .map(|r| format!(", reference {}", r.name))
                    .unwrap_or_else(|| ", no reference grating".into())
            ),
        })
    }

    /// Design name.
    pub fn design_name(&self) -> &str {
        &self.design_name
    }

    /// One line saying what is read and how.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Names of the outputs: cell labels (array) or strain gratings (module).
    pub fn outputs(&self) -> &[String] {
        &self.outputs
    }

    /// The tracked gratings' names.
    pub fn gratings(&self) -> Vec<String> {
        self.tracker
            .windows()
            .iter()
            .map(|w| w.name.clone())
            .collect()
    }

    /// The array's cell grid (cells_x, cells_y) and ulimit, g.
    pub(crate) fn array_grid(&self) -> Option<(usize, usize, f64)> {
        self.array
            .as_ref()
            .map(|a| (a.cells_x, a.cells_y, a.ulimit_g))
    }

    /// Module: the core plugged in.
    pub fn core(&self) -> Option<&str> {
        self.core.as_deref()
    }

    /// Array: each cell's centre on the sheet, mm, in the order of [`Self::outputs`].
    pub fn cell_centers_mm(&self) -> &[(f64, f64)] {
        &self.cell_centers_mm
    }

    /// The array's reconstruction method.
    pub fn method(&self) -> Option<Method> {
        self.method
    }

    /// The settings the array's method was built with (array only).
    #[cfg(test)]
    pub(crate) fn method_settings(&self) -> Option<&methods::MethodSettings> {
        self.array.as_ref().map(|a| &a.setup.settings)
    }

    /// K per strain grating, pm/N (module).
    pub fn sensitivities_pm_per_n(&self) -> Vec<f64> {
        self.module
            .as_ref()
            .map(|m| m.strain.iter().map(|&(_, k)| k).collect())
            .unwrap_or_default()
    }

    /// The tare baseline, nm, once known.
    pub fn baseline_nm(&self) -> Option<&[f64]> {
        self.tare.baseline_nm()
    }

    /// Where the tare stands.
    pub fn tare_state(&self) -> TareState {
        self.tare.state
    }

    /// The tare's settings.
    pub fn tare_settings(&self) -> &TareSettings {
        self.tare.settings()
    }

    /// Tare again from the next frame (`origin` says who asked: `key`, `control`,
    /// `python`, ...); the frames are not read until a window is at rest. Ignored
    /// without a tare.
    pub fn request_tare(&mut self, origin: &str) {
        if self.tare.state != TareState::Nominal {
            if let Some(m) = self.module.as_mut() {
                m.last_reference_shift_pm = None;
            }
        }
        self.tare.request(origin, self.frames);
    }

    /// The tare's changes since the last call, oldest first.
    pub fn take_tare_changes(&mut self) -> Vec<TareChange> {
        self.tare.take_changes()
    }

    /// Stage 1 (in order, sequential): find the gratings, take the tare, compute shifts.
    pub fn prepare(&mut self, frame: &Frame) -> Assigned {
        self.frames += 1;
        let mut wl = Vec::with_capacity(self.nominal_nm.len());
        let ambiguous = self.tracker.assign_frame(&frame.peaks_nm, &mut wl);
        let result = self.prepare_from(&wl, frame);
        Assigned {
            frame: self.frames,
            peaks_nm: wl,
            result,
            ambiguous,
        }
    }

    /// The frame's time for the tare window: its own, else since the first frame read.
    fn frame_time_s(&mut self, frame: &Frame) -> f64 {
        let origin = *self.clock_origin.get_or_insert(frame.received);
        frame.time_s.unwrap_or_else(|| {
            frame
                .received
                .saturating_duration_since(origin)
                .as_secs_f64()
        })
    }

    fn prepare_from(&mut self, wl: &[f64], frame: &Frame) -> Result<Prepared, Skip> {
        // The array needs every grating; a module can go on without one of its gratings.
        let missing: Vec<usize> = (0..wl.len()).filter(|&i| !wl[i].is_finite()).collect();
        let must_have_all = self.array.is_some();
        if !missing.is_empty() && (must_have_all || missing.len() == wl.len()) {
            let w = &self.tracker.windows()[missing[0]];
            return Err(Skip::Bad(
                "missing_peak",
                format!(
                    "{}: no peak within {}'s window {:.3} ± {:.3} nm{}",
                    frame.origin,
                    w.name,
                    w.nominal_nm,
                    w.half_width_nm,
                    if missing.len() > 1 {
                        format!(" (and {} more gratings)", missing.len() - 1)
                    } else {
                        String::new()
                    }
                ),
            ));
        }
        let t_s = self.frame_time_s(frame);
        match self.tare.push(t_s, self.frames, wl) {
            Phase::Taring => return Err(Skip::Tare),
            Phase::Refused => return Err(Skip::Refused),
            Phase::Read => {}
        }
        let mut shifts = self.shifts(wl);
        let d = self.load_shifts(&shifts, true);
        let mut below_tare = below(&d, BELOW_FRAME).is_some();
        // A frame clearly below the tare may end a window settled below it: the tare
        // held a load (or the temperature fell). Tare again on that window.
        if self.tare.state == TareState::Resting
            && below(&d, (3.0, 2.0)).is_some()
            && self.retare_if_settled_below()
        {
            shifts = self.shifts(wl);
            below_tare = false;
        }
        Ok(Prepared {
            shifts_pm: shifts,
            below_tare,
        })
    }

    /// Shifts of `wl` from the baseline, pm.
    fn shifts(&self, wl: &[f64]) -> Vec<f64> {
        let base = self.tare.baseline_nm().expect("read only once tared");
        wl.iter().zip(base).map(|(&w, &b)| (w - b) * 1e3).collect()
    }

    /// When the tare window is at rest and settled below the tare on every grating
    /// that carries load, tare on it; whether it did.
    fn retare_if_settled_below(&mut self) -> bool {
        let Some(v) = self.tare.settled() else {
            return false;
        };
        let means: Vec<f64> = v.stats.iter().map(|s| s.mean_nm).collect();
        let shifts = self.shifts(&means);
        let d = self.load_shifts(&shifts, false);
        let Some((i, drop_pm)) = below(&d, BELOW_WINDOW) else {
            return false;
        };
        let name = match &self.module {
            Some(m) => self.tracker.windows()[m.strain[i].0].name.clone(),
            None => self.tracker.windows()[i].name.clone(),
        };
        let why = format!(
            "the sensor settled {:.1} pm below the tare ({name}): the tare held a load{}",
            -drop_pm,
            if self.module.as_ref().is_some_and(|m| m.reference.is_some()) {
                ""
            } else {
                ", or the temperature fell"
            }
        );
        let frame = self.frames;
        self.tare.retare_on_window(&v, frame, "below_tare", &why);
        if let Some(m) = self.module.as_mut() {
            m.last_reference_shift_pm = None;
        }
        true
    }

    /// Each load-bearing grating's shift in the direction a load moves it, with its
    /// noise σ, pm: an array's gratings as they are (a load raises every one); a
    /// module's strain gratings temperature-compensated and signed by K (a load on the
    /// dome pushes, so its force is positive). A module's missing reference shift is
    /// the last one seen when `hold_reference` (a frame; not a window's means).
    fn load_shifts(&self, shifts: &[f64], hold_reference: bool) -> Vec<(f64, f64)> {
        let sigma = self.tare.settings().resolution_pm;
        let Some(m) = &self.module else {
            return shifts.iter().map(|&s| (s, sigma)).collect();
        };
        let reference = m.reference.and_then(|r| {
            let s = shifts[r];
            if s.is_finite() || !hold_reference {
                Some(s)
            } else {
                m.last_reference_shift_pm
            }
        });
        m.strain
            .iter()
            .map(|&(i, k)| {
                let (comp, noise) = match (m.reference, reference) {
                    (Some(r), Some(rs)) => {
                        let ratio = self.nominal_nm[i] / self.nominal_nm[r];
                        (
                            crate::grating::compensate_temperature_pm(
                                shifts[i],
                                self.nominal_nm[i],
                                rs,
                                self.nominal_nm[r],
                            ),
                            sigma * (1.0 + ratio * ratio).sqrt(),
                        )
                    }
                    _ => (shifts[i], sigma),
                };
                (comp * k.signum(), noise)
            })
            .collect()
    }

    /// Stage 2 for a module (sequential: it holds the last reference shift).
    fn forces(&mut self, p: &Prepared) -> Reading {
        let m = self.module.as_mut().expect("module");
        let reference_shift = m.reference.and_then(|r| {
            let s = p.shifts_pm[r];
            if s.is_finite() {
                m.last_reference_shift_pm = Some(s);
                Some(s)
            } else {
                m.last_reference_shift_pm
            }
        });
        let forces_n = m
            .strain
            .iter()
            .map(|&(i, k)| {
                let s = p.shifts_pm[i];
                if !s.is_finite() {
                    return None;
                }
                let comp = match (m.reference, reference_shift) {
                    (Some(r), Some(rs)) => crate::grating::compensate_temperature_pm(
                        s,
                        self.nominal_nm[i],
                        rs,
                        self.nominal_nm[r],
                    ),
                    _ => s,
                };
                Some(comp / k)
            })
            .collect();
        Reading::Forces {
            forces_n,
            delta_t_k: reference_shift.map(|rs| rs / m.reference_pm_per_k),
        }
    }

    /// Stage 2: readings of a batch of prepared frames, in order. Array frames are
    /// reconstructed in parallel (rayon) when the batch is large enough to pay for it.
    pub fn solve(&mut self, batch: &[Prepared]) -> Vec<Reading> {
        if let Some(array) = &self.array {
            let r = &array.setup;
            let one = |p: &Prepared| -> Reading {
                let Reconstruction {
                    loads_g,
                    converged,
                    residual_pm,
                    certified,
                    flags,
                    ..
                } = r.reconstruct(&p.shifts_pm);
                Reading::Loads {
                    loads_g,
                    converged,
                    residual_pm,
                    certified,
                    flags,
                }
            };
            const PARALLEL_FROM: usize = 8;
            if batch.len() >= PARALLEL_FROM {
                use rayon::prelude::*;
                batch.par_iter().map(one).collect()
            } else {
                batch.iter().map(one).collect()
            }
        } else {
            batch.iter().map(|p| self.forces(p)).collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    fn frame(peaks: Vec<f64>) -> Frame {
        Frame {
            serial: None,
            time_s: None,
            wall_clock: false,
            peaks_nm: peaks,
            received: Instant::now(),
            origin: "test".into(),
        }
    }

    #[test]
    fn module_force_is_the_compensated_shift_over_k() {
        let design =
            crate::design::parse(include_str!("../../../designs/clip-on-34mm.toml")).unwrap();
        let mut k = BTreeMap::new();
        k.insert("lambda_21".to_string(), -170.0);
        k.insert("lambda_22".to_string(), -160.0);
        let opts = InterpretOptions {
            tare_frames: 8,
            tare_s: 0.0,
            core: Some("psc2".into()),
            calibrated_k_pm_per_n: k,
            ..InterpretOptions::default()
        };
        let mut it = Interpreter::new(&design, &opts).unwrap();
        assert_eq!(
            it.outputs(),
            &["lambda_21".to_string(), "lambda_22".to_string()]
        );
        let optics = &design.fiber;
        let (l21, l22, lt) = (1540.060 + 0.05, 1530.701 - 0.03, 1560.146 + 0.01);
        // Tare: eight unloaded frames at 20 °C (identical: at rest); the eighth
        // completes the window.
        for k in 0..8 {
            let a = it.prepare(&frame(vec![lt, l21, l22]));
            assert_eq!(a.frame, k + 1);
            assert_eq!(a.result.unwrap_err(), Skip::Tare);
        }
        assert_eq!(it.tare_state(), TareState::Resting);
        // 4 N and +3 K: each strain grating moves by K·F plus its thermal shift.
        let (f, dt) = (4.0, 3.0);
        let peaks = vec![
            l21 + (-170.0 * f + optics.shift_pm(1540.060, 0.0, dt)) * 1e-3,
            l22 + (-160.0 * f + optics.shift_pm(1530.701, 0.0, dt)) * 1e-3,
            lt + optics.shift_pm(1560.146, 0.0, dt) * 1e-3,
            1600.0, // a peak of some other sensor: ignored
        ];
        let p = it.prepare(&frame(peaks)).result.unwrap();
        match &it.solve(&[p])[0] {
            Reading::Forces {
                forces_n,
                delta_t_k,
            } => {
                for v in forces_n {
                    assert!((v.unwrap() - f).abs() < 1e-6, "{forces_n:?}");
                }
                assert!((delta_t_k.unwrap() - dt).abs() < 1e-3, "{delta_t_k:?}");
            }
            r => panic!("{r:?}"),
        }
        // Without the reference peak, the last reference shift is held.
        let p = it
            .prepare(&frame(vec![
                l21 + (-170.0 * f + optics.shift_pm(1540.060, 0.0, dt)) * 1e-3,
            ]))
            .result
            .unwrap();
        match &it.solve(&[p])[0] {
            Reading::Forces { forces_n, .. } => {
                assert!((forces_n[0].unwrap() - f).abs() < 1e-6);
                assert_eq!(forces_n[1], None);
            }
            r => panic!("{r:?}"),
        }
    }

    #[test]
    fn the_array_method_follows_the_stated_resolution_as_reconstruct_does() {
        let design =
            crate::design::parse(include_str!("../../../designs/tactile-array-60x80.toml"))
                .unwrap();
        let (m, ulimit_g) = matrix_from_design(&design).unwrap();
        let problem = SensingProblem::new(m.sensitivity_pm_per_g.clone(), ulimit_g, true)
            .unwrap()
            .with_min_load_g(default_min_load_g(ulimit_g))
            .unwrap();
        let max_loads = design.array.as_ref().unwrap().max_loads;
        let prior = |resolution_pm| ReadingSettings {
            max_loads: max_loads.map_or(methods::DEFAULT_MAX_LOADS, |k| k as usize),
            resolution_pm,
        };
        // λ = 16 σ²: 4 at the paper's 0.5 pm (the default), 1 at 0.25 pm.
        for (resolution_pm, lambda) in [(0.5, 4.0), (0.25, 1.0)] {
            for method in [Some("bnb"), None] {
                let it = Interpreter::new(
                    &design,
                    &InterpretOptions {
                        tare_frames: 0,
                        method: method.map(str::to_string),
                        resolution_pm,
                        ..InterpretOptions::default()
                    },
                )
                .unwrap();
                let request = match method {
                    Some(_) => MethodRequest::named(Method::BranchAndBound),
                    None => MethodRequest::Default {
                        budget_us: DEFAULT_BUDGET_US,
                    },
                };
                let want = prepare(&problem, &prior(resolution_pm), &request, None).unwrap();
                assert_eq!(it.method(), Some(want.method));
                assert_eq!(it.method_settings(), Some(&want.settings));
                if method.is_some() {
                    assert_eq!(want.settings.penalty(), Some(lambda));
                }
            }
        }
    }

    #[test]
    fn array_frames_reconstruct_known_loads_and_missing_peaks_are_named() {
        let design =
            crate::design::parse(include_str!("../../../designs/tactile-array-60x80.toml"))
                .unwrap();
        let (m, _) = matrix_from_design(&design).unwrap();
        let mut it = Interpreter::new(
            &design,
            &InterpretOptions {
                tare_frames: 0,
                ..InterpretOptions::default()
            },
        )
        .unwrap();
        let nominal: Vec<f64> = design
            .array
            .as_ref()
            .unwrap()
            .gratings
            .iter()
            .map(|g| g.bragg_wavelength_nm)
            .collect();
        // 100 g on cell C (index 2), noise-free.
        let mut x = vec![0.0; 8];
        x[2] = 100.0;
        let y = &m.sensitivity_pm_per_g * nalgebra::DVector::from_vec(x.clone());
        let peaks: Vec<f64> = nominal
            .iter()
            .zip(y.iter())
            .map(|(l, s)| l + s * 1e-3)
            .collect();
        let p = it.prepare(&frame(peaks.clone())).result.unwrap();
        match &it.solve(&[p])[0] {
            Reading::Loads { loads_g, .. } => {
                for (got, want) in loads_g.iter().zip(&x) {
                    assert!((got - want).abs() < 0.5, "{loads_g:?}");
                }
            }
            r => panic!("{r:?}"),
        }
        let mut short = peaks;
        short.remove(3);
        match it.prepare(&frame(short)).result {
            Err(Skip::Bad(kind, msg)) => {
                assert_eq!(kind, "missing_peak");
                assert!(msg.contains("fbg4's window 1530.637"), "{msg}");
            }
            r => panic!("{r:?}"),
        }
    }
}
