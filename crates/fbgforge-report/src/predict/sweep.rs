//! A sweep shown: its chart (one colour per configuration, one dash per grating, a
//! band per configuration) and CSV, a summary table; and the paper's parametric
//! figures written as SVG + CSV with the trends each curve reproduces.

use crate::model::LoadCase;
use crate::output::{ensure_dir, write_csv};
use crate::plot::{Chart, Mark, Series, Stroke};
use crate::spec::Design;
use anyhow::Result;
use fbgforge_core::fields::InWords;
use fbgforge_model::model::sweep::{SweepResult, SweepSeries, PAPER_FIGURES};
use fbgforge_model::prediction::{
    FidelityChoice, FigureSwept, PaperFiguresRequest, SweepSink, Swept, DEFAULT_CONTACT_WARNING,
};
use std::io::Write;
use std::path::{Path, PathBuf};

/// How a sweep's output names its model.
fn fidelity_label(f: FidelityChoice) -> &'static str {
    match f {
        FidelityChoice::ClosedForm => "closed form",
        FidelityChoice::Fem => "finite elements",
        FidelityChoice::Auto => "model policy",
    }
}

/// Relative tolerance under which two curves are the same curve, drawn once.
pub const SAME_CURVE_TOLERANCE: f64 = 1e-3;

/// True when `a` and `b` are the same curve: the same swept values and shifts equal
/// within [`SAME_CURVE_TOLERANCE`] of the larger at every value.
fn same_curve(a: &SweepSeries, b: &SweepSeries) -> bool {
    let close = |p: f64, q: f64| (p - q).abs() <= SAME_CURVE_TOLERANCE * p.abs().max(q.abs());
    a.x.len() == b.x.len()
        && a.x.iter().zip(&b.x).all(|(p, q)| close(*p, *q))
        && a.shift_pm
            .iter()
            .zip(&b.shift_pm)
            .all(|(p, q)| close(*p, *q))
}

/// A configuration's legend name, e.g. `Case I · blue`.
fn config_name(case: LoadCase, insert: &Option<String>) -> String {
    match insert {
        Some(i) => format!("Case {case} · {i}"),
        None => format!("Case {case}"),
    }
}

/// Configurations drawn as one: their legend names, and the series of the first.
pub type Configuration<'a> = (Vec<String>, Vec<&'a SweepSeries>);

/// The sweep's configurations (case and insert) with their series, those whose every
/// grating's curve coincides with another's ([`same_curve`]) merged into one: the
/// names of the merged configurations, and the series of the first.
pub fn distinct_configurations(r: &SweepResult) -> Vec<Configuration<'_>> {
    let mut keys: Vec<(LoadCase, Option<String>)> = Vec::new();
    for s in &r.series {
        let key = (s.case, s.insert.clone());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    let mut groups: Vec<Configuration<'_>> = Vec::new();
    for key in keys {
        let members: Vec<_> = r
            .series
            .iter()
            .filter(|s| (s.case, s.insert.clone()) == key)
            .collect();
        let same = |g: &[&SweepSeries]| {
            g.len() == members.len()
                && g.iter()
                    .zip(&members)
                    .all(|(a, b)| a.grating == b.grating && same_curve(a, b))
        };
        match groups.iter_mut().find(|(_, g)| same(g)) {
            Some((names, _)) => names.push(config_name(key.0, &key.1)),
            None => groups.push((vec![config_name(key.0, &key.1)], members)),
        }
    }
    groups
}

/// The sweep's chart: one colour per distinct configuration (case and insert;
/// configurations whose curves coincide within 0.1 % are drawn once, the legend naming
/// them all), one dash per grating within it, and one band per configuration (the
/// envelope of its gratings' bands, outlined), with the legend beside the plot.
pub fn sweep_chart(r: &SweepResult, title: &str, log_x: bool) -> Chart {
    let mut c = Chart::new(
        title,
        r.label.clone(),
        format!("Δλ at {} N (pm)", r.force_n),
    );
    c.x_log = log_x;
    for (gi, (names, members)) in distinct_configurations(r).iter().enumerate() {
        let what = names.join(" = ");
        for (k, s) in members.iter().enumerate() {
            c = c.with(
                Series::new(
                    format!("{} · {what}", s.grating),
                    s.x.iter()
                        .copied()
                        .zip(s.shift_pm.iter().copied())
                        .collect(),
                    Mark::Line,
                )
                .with_color(gi)
                .with_stroke(Stroke::ALL[k % Stroke::ALL.len()])
                .with_role("shift"),
            );
        }
        if let Some(band) = group_band(members, r.force_n) {
            c = c.with(
                Series::new(
                    format!("band, {what} (contact readings)"),
                    Vec::new(),
                    Mark::Line,
                )
                .with_band(band)
                .with_color(gi)
                .with_stroke(Stroke::Dotted)
                .with_role("band"),
            );
        }
    }
    c
}

/// The band of K of one configuration's gratings as a band of the shift at force `f`:
/// their envelope at each value (`None` when some grating has no band).
fn group_band(members: &[&SweepSeries], f: f64) -> Option<Vec<(f64, f64, f64)>> {
    let first = members[0];
    let banded = members
        .iter()
        .all(|s| s.band_pm_per_n.len() == s.x.len() && s.x.len() == first.x.len());
    if !banded || first.x.is_empty() {
        return None;
    }
    Some(
        (0..first.x.len())
            .map(|i| {
                let (lo, hi) = members.iter().fold((f64::MAX, f64::MIN), |(a, b), s| {
                    let [p, q] = s.band_pm_per_n[i];
                    (a.min(p * f).min(q * f), b.max(p * f).max(q * f))
                });
                (first.x[i], lo, hi)
            })
            .collect(),
    )
}

/// The sweep's numbers as CSV: one row per series and value.
pub fn sweep_csv(r: &SweepResult, path: &Path) -> Result<()> {
    let header = [
        "param",
        "value",
        "grating",
        "case",
        "insert",
        "force_n",
        "band_low_pm_per_n",
        "band_high_pm_per_n",
        "shift_pm",
        "sensitivity_pm_per_n",
    ];
    let mut rows = Vec::new();
    for s in &r.series {
        for i in 0..s.x.len() {
            let band = |k: usize| {
                s.band_pm_per_n
                    .get(i)
                    .filter(|_| s.band_pm_per_n.len() == s.x.len())
                    .map_or(String::new(), |b| format!("{:.6}", b[k]))
            };
            rows.push(vec![
                r.param.clone(),
                format!("{}", s.x[i]),
                s.grating.clone(),
                s.case.to_string(),
                s.insert.clone().unwrap_or_default(),
                format!("{}", r.force_n),
                band(0),
                band(1),
                format!("{:.6}", s.shift_pm[i]),
                format!("{:.6}", s.sensitivity_pm_per_n[i]),
            ]);
        }
    }
    write_csv(path, &header, &rows)
}

/// Say so when Case I curves by the FE rest on the shipped default contact radius.
fn default_contact_note(
    out: &mut impl Write,
    (design, words): (&Design, InWords),
    f: FidelityChoice,
    case_i: bool,
) -> Result<()> {
    let default = design
        .module
        .as_ref()
        .is_some_and(|m| m.contact_radius_is_default());
    if case_i && default && f != FidelityChoice::ClosedForm {
        writeln!(
            out,
            "{}",
            words(&format!("note: Case I: {DEFAULT_CONTACT_WARNING}"))
        )?;
    }
    Ok(())
}

/// A sweep written as a chart and a CSV, with a summary printed: the first and last
/// shift of every series, and where the files went.
pub struct SweepFiles<W: Write> {
    svg: PathBuf,
    csv: PathBuf,
    out: W,
    words: InWords,
}

impl<W: Write> SweepFiles<W> {
    /// The chart into `svg`, the numbers into `csv`, the summary to `out`, naming
    /// options in `words`.
    pub fn new(svg: PathBuf, csv: PathBuf, out: W, words: InWords) -> Self {
        SweepFiles {
            svg,
            csv,
            out,
            words,
        }
    }
}

impl<W: Write> SweepSink for SweepFiles<W> {
    fn swept(&mut self, s: &Swept) -> Result<()> {
        let (r, q) = (s.result, s.request);
        let label = fidelity_label(q.fidelity);
        let title = format!(
            "{}: Δλ at {} N vs {} ({label})",
            s.design.name, q.force_n, q.param.name
        );
        sweep_chart(r, &title, s.log).write_svg(&self.svg)?;
        sweep_csv(r, &self.csv)?;
        let out = &mut self.out;
        writeln!(
            out,
            "{}: {} over {}..{} ({} {} steps), F = {} N\nmodel: {label}",
            s.design.name,
            q.param.name,
            q.start,
            q.stop,
            q.steps,
            if s.log { "log" } else { "linear" },
            q.force_n,
        )?;
        writeln!(
            out,
            "{:<36} {:>12} {:>12}",
            "series", "Δλ first pm", "Δλ last pm"
        )?;
        for x in &r.series {
            writeln!(
                out,
                "{:<36} {:>+12.1} {:>+12.1}",
                x.label(),
                x.shift_pm.first().copied().unwrap_or(f64::NAN),
                x.shift_pm.last().copied().unwrap_or(f64::NAN)
            )?;
        }
        let case_i = r.series.iter().any(|x| x.case == LoadCase::I);
        default_contact_note(out, (s.design, self.words), q.fidelity, case_i)?;
        writeln!(
            out,
            "wrote {} and {}",
            self.svg.display(),
            self.csv.display()
        )?;
        Ok(())
    }
}

/// The paper's figures written into a folder (each as SVG + CSV, and `trends.csv`),
/// with a line per figure and per curve's trend printed.
pub struct PaperFigureFiles<W: Write> {
    dir: PathBuf,
    out: W,
    words: InWords,
    /// Rows of `trends.csv`: figure, model, reproduced, detail.
    trends: Vec<Vec<String>>,
}

impl<W: Write> PaperFigureFiles<W> {
    /// The figures into `dir`, the lines to `out`, naming options in `words`.
    pub fn new(dir: PathBuf, out: W, words: InWords) -> Self {
        PaperFigureFiles {
            dir,
            out,
            words,
            trends: Vec::new(),
        }
    }
}

impl<W: Write> SweepSink for PaperFigureFiles<W> {
    fn figures_begin(&mut self, _r: &PaperFiguresRequest) -> Result<()> {
        ensure_dir(&self.dir)
    }

    fn figure(&mut self, f: &FigureSwept) -> Result<()> {
        let (fig, r) = (f.figure, f.result);
        let title = format!("{} ({})", fig.title, fidelity_label(f.request.fidelity));
        sweep_chart(r, &title, false).write_svg(&self.dir.join(format!("{}.svg", fig.id)))?;
        sweep_csv(r, &self.dir.join(format!("{}.csv", fig.id)))?;
        let first = &r.series[0];
        writeln!(
            self.out,
            "{:<18} {:<58} Δλ {:+9.2} → {:+9.2} pm ({})",
            fig.id,
            fig.title,
            first.shift_pm[0],
            first.shift_pm[first.shift_pm.len() - 1],
            first.label()
        )?;
        for t in f.trends {
            let v = &t.verdict;
            writeln!(
                self.out,
                "    {:<62} {:<14} {}",
                t.model,
                if v.reproduced {
                    "reproduced"
                } else {
                    "NOT reproduced"
                },
                v.detail
            )?;
            self.trends.push(vec![
                fig.id.to_string(),
                t.model.clone(),
                v.reproduced.to_string(),
                v.detail.clone(),
            ]);
        }
        Ok(())
    }

    fn figures_end(&mut self, design: &Design, r: &PaperFiguresRequest) -> Result<()> {
        default_contact_note(&mut self.out, (design, self.words), r.fidelity, true)?;
        write_csv(
            &self.dir.join("trends.csv"),
            &["figure", "model", "reproduced", "detail"],
            &self.trends,
        )?;
        writeln!(
            self.out,
            "wrote {} figures (SVG + CSV) and trends.csv to {}, model: {}",
            PAPER_FIGURES.len(),
            self.dir.display(),
            fidelity_label(r.fidelity)
        )?;
        Ok(())
    }
}
