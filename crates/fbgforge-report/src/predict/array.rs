//! An array design's prediction: the sensitivity map over the sheet (SVG heat maps and
//! their CSV), and the predicted sensing matrix or the response to one load, as a
//! table or as JSON.

use crate::output::write_csv;
use crate::plot::{HeatMaps, HeatPanel};
use crate::spec::Design;
use anyhow::Result;
use fbgforge_array::predict::{ArrayPredictor, SensitivityMap};
use fbgforge_array::sheet::spectrum::ArraySpectra;
use std::io::Write;
use std::path::Path;

/// The response of every grating to one load (`ArrayPredictor::load_at`).
pub type LoadResponse = fbgforge_array::predict::LoadResponse;

/// The sensitivity map as heat maps, one panel per grating, with the fibers, the
/// cells' borders and each grating marked.
pub(crate) fn map_chart(design: &Design, p: &ArrayPredictor, map: &SensitivityMap) -> HeatMaps {
    let a = design.array.as_ref().expect("an array design");
    let (sx, sy) = p.sheet_mm();
    let mut lines: Vec<Vec<(f64, f64)>> = a
        .fiber_x_mm
        .iter()
        .map(|&x| vec![(x, -sy / 2.0), (x, sy / 2.0)])
        .collect();
    for i in 1..a.cells_x {
        let x = -sx / 2.0 + sx * i as f64 / a.cells_x as f64;
        lines.push(vec![(x, -sy / 2.0), (x, sy / 2.0)]);
    }
    for j in 1..a.cells_y {
        let y = -sy / 2.0 + sy * j as f64 / a.cells_y as f64;
        lines.push(vec![(-sx / 2.0, y), (sx / 2.0, y)]);
    }
    let panels = map
        .gratings
        .iter()
        .enumerate()
        .map(|(g, name)| {
            let v = &map.values_pm_per_g[g];
            let (lo, hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                    (l.min(x), h.max(x))
                });
            HeatPanel {
                title: format!("{name}: {lo:.3} … {hi:.3} pm/g"),
                x: map.x_mm.clone(),
                y: map.y_mm.clone(),
                values: (0..v.nrows())
                    .map(|j| v.row(j).iter().copied().collect())
                    .collect(),
                points: vec![map.grating_xy_mm[g]],
                lines: lines.clone(),
            }
        })
        .collect();
    HeatMaps {
        title: format!(
            "{}: sensitivity to 1 g on the indenter centred at (x, y), {} model (red: red shift, blue: blue shift)",
            design.name,
            p.kind().name()
        ),
        x_label: "x (mm)".into(),
        y_label: "y (mm)".into(),
        panels,
    }
}

/// Write the sensitivity map as `svg` (heat maps) and `csv` (its numbers).
pub fn write_map(
    design: &Design,
    p: &ArrayPredictor,
    map: &SensitivityMap,
    (svg, csv): (&Path, &Path),
) -> Result<()> {
    map_chart(design, p, map).write_svg(svg)?;
    let (header, rows) = map.csv_rows();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    write_csv(csv, &header, &rows)
}

/// An array's prediction: the design, its predictor, the map's files, and the response
/// to one load when one was asked for (else the whole matrix is shown).
pub struct ArrayPrediction<'a> {
    /// The design.
    pub design: &'a Design,
    /// The predictor (its model and description).
    pub predictor: &'a ArrayPredictor,
    /// The response to 1 g at (x, y) mm, when asked for.
    pub load: Option<((f64, f64), &'a LoadResponse)>,
    /// The map's SVG and CSV.
    pub map_files: (&'a Path, &'a Path),
    /// Each grating's spectrum under a load on each cell (sheet model; `None` when not
    /// asked for or by the kernel).
    pub spectra: Option<&'a ArraySpectra>,
}

/// The prediction as pretty JSON.
pub fn write_json(out: &mut impl Write, a: &ArrayPrediction) -> Result<()> {
    let (design, p) = (a.design, a.predictor);
    let (svg, csv) = a.map_files;
    let doc = match a.load {
        Some((_, r)) => serde_json::json!({
            "design": design.name,
            "model": p.kind().name(),
            "model_description": p.description(),
            "load_at_mm": r.load_at_mm,
            "gratings": r.gratings,
            "sensitivity_pm_per_g": r.sensitivity_pm_per_g,
            "map": {"svg": svg, "csv": csv},
        }),
        None => {
            let m = p.matrix();
            let rows: Vec<Vec<f64>> = (0..m.n_gratings())
                .map(|i| m.sensitivity_pm_per_g.row(i).iter().copied().collect())
                .collect();
            serde_json::json!({
                "design": design.name,
                "model": p.kind().name(),
                "model_description": p.description(),
                "gratings": m.gratings,
                "cells": m.cells,
                "sensitivity_pm_per_g": rows,
                "map": {"svg": svg, "csv": csv},
            })
        }
    };
    let mut doc = doc;
    if let Some(s) = a.spectra {
        doc["spectrum"] = serde_json::to_value(s)?;
    }
    writeln!(out, "{}", serde_json::to_string_pretty(&doc)?)?;
    Ok(())
}

/// The prediction as a table: the response to the load, or the matrix (gratings ×
/// cells), then where the map went.
pub fn write_table(out: &mut impl Write, a: &ArrayPrediction) -> Result<()> {
    let (design, p) = (a.design, a.predictor);
    match a.load {
        Some(((x, y), r)) => {
            writeln!(
                out,
                "{}: response to 1 g on the {} mm indenter centred at ({x}, {y}) mm",
                design.name,
                design
                    .array
                    .as_ref()
                    .map_or(20.0, |arr| arr.indenter_diameter())
            )?;
            writeln!(out, "model: {}", p.description())?;
            writeln!(out, "{:<10} {:>12}", "grating", "pm/g")?;
            for (g, v) in r.gratings.iter().zip(&r.sensitivity_pm_per_g) {
                writeln!(out, "{g:<10} {v:>12.5}")?;
            }
        }
        None => {
            let m = p.matrix();
            writeln!(
                out,
                "{}: predicted sensing matrix, pm/g (gratings × cells, 1 g on the indenter centred on each cell)",
                design.name
            )?;
            writeln!(out, "model: {}", p.description())?;
            // Eight cells of nine columns beside the names fit 80 columns; a wider
            // array is printed in blocks of cells (as numpy prints a wide array).
            let per_block = (crate::terminal::WIDTH - 8) / 9;
            let blocks = m.cells.len().div_ceil(per_block).max(1);
            for b in 0..blocks {
                let cols = b * per_block..((b + 1) * per_block).min(m.cells.len());
                if blocks > 1 {
                    writeln!(
                        out,
                        "cells {}–{} of {}:",
                        cols.start + 1,
                        cols.end,
                        m.cells.len()
                    )?;
                }
                write!(out, "{:<8}", "pm/g")?;
                for c in &m.cells[cols.clone()] {
                    write!(out, "{c:>9}")?;
                }
                writeln!(out)?;
                for (g, row) in m.gratings.iter().zip(m.sensitivity_pm_per_g.row_iter()) {
                    write!(out, "{g:<8}")?;
                    for k in cols.clone() {
                        write!(out, "{:>9.5}", row[k])?;
                    }
                    writeln!(out)?;
                }
            }
        }
    }
    if let Some(s) = a.spectra {
        write_spectra(out, s)?;
    }
    let (svg, csv) = a.map_files;
    writeln!(
        out,
        "sensitivity map: {} and {}",
        svg.display(),
        csv.display()
    )?;
    Ok(())
}

/// Per grating: the cell that moves it most (its peak shift and FWHM change at the top
/// of the range), the largest FWHM change over the cells, and whether it stays one
/// clean peak under every cell (else the cell and load where it stops); then the
/// warnings.
fn write_spectra(out: &mut impl Write, s: &ArraySpectra) -> Result<()> {
    writeln!(
        out,
        "Reflection spectrum (transfer-matrix model on the sheet model's strain along each grating), indenter on each cell, one clean peak checked over 0–{} g (array.ulimit_g):",
        s.force_range_g
    )?;
    writeln!(
        out,
        "  {:<8} {:>4} {:>9} {:>7} {:>8} {:>8} {:>7}  one clean peak",
        "grating", "cell", "shift", "FWHM", "ΔFWHM", "max|ΔF|", "span"
    )?;
    writeln!(
        out,
        "  {:<8} {:>4} {:>9} {:>7} {:>8} {:>8} {:>7}",
        "", "", "pm", "pm", "%", "%", "µε/N"
    )?;
    let mut names: Vec<&str> = s.loads.iter().map(|l| l.grating.as_str()).collect();
    names.dedup();
    for name in names {
        let loads: Vec<_> = s.loads.iter().filter(|l| l.grating == name).collect();
        let Some(main) = loads.iter().max_by(|a, b| {
            a.spectrum
                .peak_shift_pm
                .abs()
                .total_cmp(&b.spectrum.peak_shift_pm.abs())
        }) else {
            continue;
        };
        let widest = loads
            .iter()
            .map(|l| l.spectrum.fwhm_change_at_range_pct.abs())
            .fold(0.0, f64::max);
        let span = loads
            .iter()
            .map(|l| l.spectrum.strain_span_microstrain_per_n)
            .fold(0.0, f64::max);
        let stop = loads
            .iter()
            .filter_map(|l| l.clean_limit_g().map(|g| (g, l)))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let verdict = match stop {
            _ if loads.iter().any(|l| !l.spectrum.clean_unloaded) => {
                "not clean unloaded".to_string()
            }
            Some((g, l)) => format!(
                "stops at {g:.1} g on cell {}",
                l.cell.as_deref().unwrap_or("?")
            ),
            None => "clean on every cell".to_string(),
        };
        writeln!(
            out,
            "  {:<8} {:>4} {:>9.2} {:>7.1} {:>+8.3} {:>8.3} {:>7.3}  {verdict}",
            name,
            main.cell.as_deref().unwrap_or("-"),
            main.spectrum.peak_shift_pm,
            main.spectrum.fwhm_pm,
            main.spectrum.fwhm_change_pct,
            widest,
            span,
        )?;
    }
    for w in &s.warnings {
        writeln!(out, "  warning: {w}")?;
    }
    Ok(())
}
