//! The spectrum each array grating will make (`fbgforge_array::sheet::spectrum`,
//! docs/spectra.md §8.6): the sheet model's strain along the grating, through the
//! transfer-matrix model, over the array's force range.

use crate::common;
use fbgforge::array::sheet::spectrum::{array_spectra, load_spectrum, profile_mean};
use fbgforge::array::sheet::{gratings_of, SheetModel};
use fbgforge::profile::ArrayLayout;
use fbgforge::spec::Design;
use fbgforge::spectra::grating::{
    auto_grid, reflection_shape, spectrum_shape, Apodisation, CleanPeakCriteria, StrainProfile,
};

const N_PER_G: f64 = 9.80665e-3;

#[test]
fn the_profile_mean_is_the_sensing_matrix_entry_of_the_same_solve() {
    // One source of truth: the trapezoid mean of the sampled profile is the grating's
    // reading of the same forces (the matrix's entry in strain per newton), 1e-9.
    let d = common::shipped("tactile-array-60x80.toml");
    let sol = SheetModel::from_design(&d).unwrap().solve().unwrap();
    let gratings = gratings_of(&d).unwrap();
    let cells = ArrayLayout::from_array(d.array.as_ref().unwrap()).cell_centers_mm;
    let m = sol.strain_per_n(&gratings, &cells);
    let scale = m.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for (i, g) in gratings.iter().enumerate() {
        for (c, &cell) in cells.iter().enumerate() {
            let (z, e) = sol.strain_profile_per_n(g, cell);
            assert!(z.len() >= 4, "{} samples", z.len());
            assert!((z[z.len() - 1] - g.length_mm).abs() < 1e-12);
            let mean = profile_mean(&z, &e);
            assert!(
                (mean - m[(i, c)]).abs() <= 1e-9 * m[(i, c)].abs().max(1e-3 * scale),
                "grating {i} cell {c}: profile mean {mean:e} vs matrix {:e}",
                m[(i, c)]
            );
        }
    }
    // The spectra of every grating under every cell: the shift per newton is the
    // matrix's K (pm/N) where the shift is well above the grid's resolution.
    let s = array_spectra(&d, &sol).unwrap();
    assert_eq!(s.loads.len(), gratings.len() * cells.len());
    let pm_per_strain: Vec<f64> = d
        .array
        .as_ref()
        .unwrap()
        .gratings
        .iter()
        .map(|g| d.fiber.shift_pm(g.bragg_wavelength_nm, 1.0, 0.0))
        .collect();
    for (k, l) in s.loads.iter().enumerate() {
        let (i, c) = (k / cells.len(), k % cells.len());
        assert!((l.mean_microstrain_per_n - 1e6 * m[(i, c)]).abs() <= 1e-9 * 1e6 * scale);
        let k_pm_per_n = m[(i, c)] * pm_per_strain[i];
        let shift = l.spectrum.peak_shift_pm;
        println!(
            "{} {:?}: K·F {:.3} pm, shift {:.3} pm, ΔFWHM {:+.3} %, span {:.3} µε/N",
            l.grating,
            l.cell,
            k_pm_per_n * l.spectrum.force_range_n,
            shift,
            l.spectrum.fwhm_change_pct,
            l.spectrum.strain_span_microstrain_per_n
        );
        assert!(
            (shift - k_pm_per_n * l.spectrum.force_range_n).abs()
                < 0.005 * (k_pm_per_n * l.spectrum.force_range_n).abs() + 0.05,
            "{} on {:?}: shift {shift} pm vs K·F {} pm",
            l.grating,
            l.cell,
            k_pm_per_n * l.spectrum.force_range_n
        );
        assert!(l.spectrum.clean_over_range);
    }
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

/// The shipped array with weak, Gaussian-apodised 10 mm gratings (Δn = 1e-5, modulation
/// FWHM 0.3·L): the weak-grating closed form of docs/spectra.md §8 holds for them.
fn weak_long_gratings(ulimit_g: f64) -> Design {
    let mut d = common::shipped("tactile-array-60x80.toml");
    d.fiber.index_modulation = 1e-5;
    d.fiber.apodisation = Apodisation::Gaussian { fwhm_fraction: 0.3 };
    let a = d.array.as_mut().unwrap();
    a.ulimit_g = ulimit_g;
    for g in &mut a.gratings {
        g.length_mm = 10.0;
    }
    d
}

/// The weak-grating (first Born) reflection of `g` under `strain`, by quadrature of
/// |∫ κ(z)·exp(−2i∫₀^z σ̂(z′)dz′) dz|² on `grid` (nm): a model independent of the
/// transfer matrices, exact as Δn → 0. Returns (peak nm, FWHM pm).
fn born_shape(g: &fbgforge::spectra::Grating, strain: &StrainProfile, grid: &[f64]) -> (f64, f64) {
    let n = 4000;
    let dz = g.length_mm / n as f64;
    let z: Vec<f64> = (0..n).map(|k| (k as f64 + 0.5) * dz).collect();
    let bragg_mm: Vec<f64> = z
        .iter()
        .map(|&zz| g.local_bragg_nm(strain.at(zz, g.length_mm)) * 1e-6)
        .collect();
    let a: Vec<f64> = z
        .iter()
        .map(|&zz| g.apodisation.profile(zz, g.length_mm))
        .collect();
    let r: Vec<f64> = grid
        .iter()
        .map(|&w| {
            let lambda = w * 1e-6;
            let kappa = std::f64::consts::PI * g.index_modulation / lambda;
            let (mut phase, mut re, mut im) = (0.0f64, 0.0f64, 0.0f64);
            for k in 0..n {
                let sigma =
                    2.0 * std::f64::consts::PI * g.n_eff * (1.0 / lambda - 1.0 / bragg_mm[k]);
                let mid = phase + sigma * dz; // phase at the piece's centre (2σ·dz/2)
                re += kappa * a[k] * mid.cos() * dz;
                im -= kappa * a[k] * mid.sin() * dz;
                phase += 2.0 * sigma * dz;
            }
            re * re + im * im
        })
        .collect();
    let s = reflection_shape(grid, &r, None, &CleanPeakCriteria::default()).unwrap();
    (s.peak_wavelength_nm, s.fwhm_pm)
}

/// Least-squares slope of a profile, per mm.
fn slope(z: &[f64], e: &[f64]) -> f64 {
    let n = z.len() as f64;
    let (mz, me) = (z.iter().sum::<f64>() / n, e.iter().sum::<f64>() / n);
    let szz: f64 = z.iter().map(|v| (v - mz).powi(2)).sum();
    let sze: f64 = z.iter().zip(e).map(|(a, b)| (a - mz) * (b - me)).sum();
    sze / szz
}

#[test]
fn a_load_on_the_grating_strains_it_evenly_and_a_load_off_it_chirps_it_as_the_born_model_says() {
    let d = weak_long_gratings(1e6);
    let sol = SheetModel::from_design(&d).unwrap().solve().unwrap();
    let i = 2; // fbg3 at (−7.5, 12.5) on fiber 2
    let g = gratings_of(&d).unwrap()[i];
    let x = d.array.as_ref().unwrap().fiber_x_mm[g.fiber];
    let grating = d.bragg_grating("fbg3").unwrap();
    let criteria = CleanPeakCriteria::default();
    let s0 = spectrum_shape(&grating, &StrainProfile::Uniform(0.0), &criteria).unwrap();

    // Centred: the strain along the grating is symmetric about its centre (no
    // gradient), so the peak moves by λ_B(1 − p_e) times the mean strain.
    let on = load_spectrum(&d, &sol, i, ((x, g.y_mm), None)).unwrap();
    // Centred: the strain peaks inside the grating and has next to no gradient (the
    // fiber's far ends, 42.5 and 17.5 mm away, break the symmetry slightly).
    let span_on = on.spectrum.strain_span_microstrain_per_n;
    let slope_on = slope(&on.profile_z_mm, &on.profile_microstrain_per_n);
    let (first, last) = (
        on.profile_microstrain_per_n[0],
        *on.profile_microstrain_per_n.last().unwrap(),
    );
    assert!(on.mean_microstrain_per_n > first.max(last), "{on:?}");
    assert!((slope_on * g.length_mm).abs() < 0.25 * span_on, "{on:?}");

    // Off the grating along its fiber: one cell (30 mm) away the strain along it is
    // curved (a dip); 8 mm from its centre (3 mm beyond its end) it is mostly a
    // gradient. Each chirps the reflection at a large enough load; the check is
    // independent of the transfer matrices: the weak-grating (Born) reflection of the
    // same profile at the force where it stops being one clean peak (the model is
    // linear: forces of thousands of newtons stand for a sheet and a grating that
    // strain more; the chirp's shape, not its level, is under test).
    let (_, born_fwhm0) = born_shape(
        &grating,
        &StrainProfile::Uniform(0.0),
        &auto_grid(&grating, &StrainProfile::Uniform(0.0)),
    );
    assert!((s0.fwhm_pm / born_fwhm0 - 1.0).abs() < 0.01);
    for (dy, gradient) in [(-30.0, false), (-8.0, true)] {
        let off = load_spectrum(&d, &sol, i, ((x, g.y_mm + dy), None)).unwrap();
        let k = slope(&off.profile_z_mm, &off.profile_microstrain_per_n);
        let span = off.spectrum.strain_span_microstrain_per_n;
        assert!(span > 0.0);
        if gradient {
            assert!((k * g.length_mm).abs() > 0.5 * span, "{off:?}");
        }
        let f = off
            .spectrum
            .clean_limit_force_n
            .expect("stops inside 0–1e6 g");
        assert!(!off.spectrum.clean_over_range);
        let profile = StrainProfile::samples(
            off.profile_z_mm.clone(),
            off.profile_microstrain_per_n
                .iter()
                .map(|v| 1e-6 * v * f)
                .collect(),
        )
        .unwrap();
        let tmm = spectrum_shape(&grating, &profile, &criteria).unwrap();
        let (born_peak, born_fwhm) = born_shape(&grating, &profile, &auto_grid(&grating, &profile));
        println!(
            "dy {dy} mm: stops at {f:.1} N; there FWHM {:.2} pm (TMM) vs {born_fwhm:.2} pm (Born), shift {:.2} vs {:.2} pm",
            tmm.fwhm_pm,
            tmm.peak_shift_pm,
            1e3 * (born_peak - grating.bragg_wavelength_nm)
        );
        assert!(tmm.fwhm_change_pct > 20.0, "{tmm:?}");
        assert!(
            (tmm.fwhm_pm / born_fwhm - 1.0).abs() < 0.02,
            "{tmm:?} vs {born_fwhm}"
        );
        assert!(
            (tmm.peak_shift_pm - 1e3 * (born_peak - grating.bragg_wavelength_nm)).abs()
                < 0.05 * s0.fwhm_pm
        );
    }
}

#[test]
fn a_centred_load_on_the_shipped_array_moves_the_peak_by_the_mean_strain() {
    // At the shipped range (250 g) on the shipped 3 mm gratings: the photo-elastic rule
    // on the profile's mean, one clean peak, the FWHM unchanged.
    let d = common::shipped("tactile-array-60x80.toml");
    let sol = SheetModel::from_design(&d).unwrap().solve().unwrap();
    for (i, g) in gratings_of(&d).unwrap().iter().enumerate() {
        let x = d.array.as_ref().unwrap().fiber_x_mm[g.fiber];
        let on = load_spectrum(&d, &sol, i, ((x, g.y_mm), None)).unwrap();
        let grating = d.bragg_grating(&on.grating).unwrap();
        let f = 250.0 * N_PER_G;
        assert!((on.spectrum.force_range_n - f).abs() < 1e-12);
        let expected_pm =
            grating.strain_sensitivity_pm_per_microstrain() * on.mean_microstrain_per_n * f;
        assert!(
            (on.spectrum.peak_shift_pm / expected_pm - 1.0).abs() < 0.005,
            "{}: {} pm vs {expected_pm} pm",
            on.grating,
            on.spectrum.peak_shift_pm
        );
        assert!(on.spectrum.clean_over_range && on.spectrum.fwhm_change_pct.abs() < 0.1);
    }
}

#[test]
fn an_array_grating_that_chirps_inside_the_range_is_warned_with_its_cell_and_load() {
    let d = weak_long_gratings(2e4);
    let sol = SheetModel::from_design(&d).unwrap().solve().unwrap();
    let s = array_spectra(&d, &sol).unwrap();
    let names: Vec<String> = d
        .array
        .as_ref()
        .unwrap()
        .gratings
        .iter()
        .map(|g| g.name.clone())
        .collect();
    let mut warned = 0;
    for name in &names {
        let first = s
            .loads
            .iter()
            .filter(|l| &l.grating == name)
            .filter_map(|l| l.clean_limit_g().map(|g| (g, l)))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let mine: Vec<&String> = s
            .warnings
            .iter()
            .filter(|w| w.contains(&format!("`{name}`")))
            .collect();
        match first {
            None => assert!(mine.is_empty(), "{mine:?}"),
            Some((g, l)) => {
                warned += 1;
                assert_eq!(mine.len(), 1, "{mine:?}");
                let cell = l.cell.as_deref().unwrap();
                assert!(
                    mine[0].contains(&format!("on cell {cell} "))
                        && mine[0].contains(&format!("at {g:.1} g")),
                    "{}",
                    mine[0]
                );
                assert!(g > 0.0 && g < 2e4);
            }
        }
    }
    assert!(warned > 0);

    // The command line: the table states the warning; the JSON carries every load.
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("weak-array.toml");
    std::fs::write(&spec, d.to_toml()).unwrap();
    let map = dir.path().join("map");
    let run = |extra: &[&str]| {
        let out = common::bin()
            .arg("predict")
            .arg(&spec)
            .arg("--map-dir")
            .arg(&map)
            .args(extra)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    // The table wraps long lines at 80 columns: compare with the wraps joined.
    let flat = |t: &str| t.split_whitespace().collect::<Vec<_>>().join(" ");
    let table = run(&[]);
    assert!(table.contains("Reflection spectrum"), "{table}");
    assert!(table.lines().all(|l| l.chars().count() <= 80), "{table}");
    for w in &s.warnings {
        assert!(flat(&table).contains(&flat(w)), "{w} not in {table}");
    }
    let v: serde_json::Value = serde_json::from_str(&run(&["--json"])).unwrap();
    assert_eq!(v["spectrum"]["loads"].as_array().unwrap().len(), 48);
    assert_eq!(
        v["spectrum"]["warnings"].as_array().unwrap().len(),
        s.warnings.len()
    );
    let v: serde_json::Value = serde_json::from_str(&run(&["--json", "--no-spectrum"])).unwrap();
    assert!(v.get("spectrum").is_none());
}
