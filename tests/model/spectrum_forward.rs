//! The spectrum a design will make (`prediction::spectrum`, docs/spectra.md §8): the
//! FE strain profile along each grating, through the transfer-matrix model, over the
//! design's force range.

use crate::common;
use fbgforge::fem::{self, solve_configuration, Configuration, ContactReading, FemOptions};
use fbgforge::model::LoadCase;
use fbgforge::prediction::spectrum::{forward, GratingSpectrum, ProfileSource};
use fbgforge::prediction::{predict, FidelityChoice, PredictionRequest};
use fbgforge::profile::{module_gratings, ModuleProfile};
use fbgforge::spec::{Design, GratingRole};
use fbgforge::spectra::grating::{
    clean_peak_limit, spectrum_shape, CleanPeakCriteria, LoadCase as SpectrumLoad, StrainProfile,
};

fn config(core: &str, case: LoadCase, insert: Option<&str>) -> Configuration {
    Configuration {
        core: core.into(),
        case,
        insert: insert.map(String::from),
    }
}

#[test]
fn fe_profile_mean_is_the_mean_strain_reading_of_the_same_solve() {
    // (a) The profile is sampled at the mean's own quadrature points, so its weighted
    // mean is the existing reading of the same solution, not an approximation of it.
    let d = common::shipped("clip-on-34mm.toml");
    let m = d.module.as_ref().unwrap();
    let profile = ModuleProfile::from_module(m);
    let gratings: Vec<_> = module_gratings(m, &profile)
        .into_iter()
        .filter(|g| g.role == GratingRole::Strain)
        .collect();
    for (case, insert) in [(LoadCase::II, None), (LoadCase::I, Some("blue"))] {
        let material = &m.cores[0].material;
        let insert_material = insert.map(|i| {
            m.inserts
                .iter()
                .find(|x| x.name == i)
                .unwrap()
                .material
                .clone()
        });
        let model = fem::module::build(
            &d,
            material,
            insert_material.as_deref(),
            case,
            &FemOptions::level(1),
        )
        .unwrap();
        let sol = model.problem.solve().unwrap();
        for g in gratings
            .iter()
            .filter(|g| g.core.as_deref() == Some("psc1"))
        {
            let mean = model
                .mean_axial_strain(&sol, g.z_start_mm, g.z_end_mm)
                .unwrap();
            let p = model
                .axial_strain_profile(&sol, g.z_start_mm, g.z_end_mm)
                .unwrap();
            assert!(p.z_mm.len() >= 48, "{} samples", p.z_mm.len());
            assert!(p.z_mm.windows(2).all(|w| w[1] > w[0]));
            assert!(p.z_mm[0] > 0.0 && *p.z_mm.last().unwrap() < g.z_end_mm - g.z_start_mm);
            assert!(
                ((p.mean() - mean) / mean).abs() < 1e-9,
                "{} {case:?}: profile mean {:e} vs reading {mean:e}",
                g.name,
                p.mean()
            );
        }
    }
    // The policy's solve (Richardson-extrapolated level 1) carries the profile of the
    // fine mesh shifted by the step: its mean is the extrapolated strain per newton.
    let r = solve_configuration(
        &d,
        &config("psc1", LoadCase::II, None),
        &FemOptions::default(),
        crate::fe_cache(),
    )
    .unwrap();
    assert_eq!(r.strain_profile_per_n.len(), r.strain_per_n.len());
    for ((name, _, e), p) in r.strain_per_n.iter().zip(&r.strain_profile_per_n) {
        assert!(((p.mean() - e) / e).abs() < 1e-9, "{name}");
    }
}

#[test]
fn a_uniform_profile_shifts_by_the_photoelastic_rule_without_widening() {
    // (b) ε uniform along the grating: Δλ = λ_B(1 − p_e)ε and no FWHM change, at the
    // design's grating (5 mm, Δn = 2·10⁻⁴) and at both signs of the strain.
    let d = common::shipped("clip-on-34mm.toml");
    let g = d.bragg_grating("lambda_11").unwrap();
    for per_n in [-30e-6, 25e-6] {
        let s = forward(
            &g,
            &StrainProfile::Uniform(per_n),
            10.0,
            20.0,
            &CleanPeakCriteria::default(),
        )
        .unwrap();
        let expected = d.fiber.shift_pm(g.bragg_wavelength_nm, 10.0 * per_n, 0.0);
        assert!(
            (s.peak_shift_pm - expected).abs() < 0.2,
            "shift {} pm vs λ_B(1 − p_e)ε = {expected} pm",
            s.peak_shift_pm
        );
        assert!(
            s.fwhm_change_pct.abs() < 0.2,
            "ΔFWHM {} %",
            s.fwhm_change_pct
        );
        assert!(s.fwhm_change_at_range_pct.abs() < 0.2);
        assert!(s.clean_over_range && s.clean_limit_force_n.is_none());
        assert!(s.strain_span_microstrain_per_n.abs() < 1e-9);
    }
}

fn spectra(d: &Design, request: &PredictionRequest) -> Vec<(String, f64, GratingSpectrum)> {
    predict(d, request)
        .unwrap()
        .into_iter()
        .map(|r| {
            let p = &r.detail.prediction;
            (
                format!("{} {}", p.grating, config_label(p)),
                p.sensitivity_pm_per_n,
                r.spectrum.expect("asked for the spectrum"),
            )
        })
        .collect()
}

fn config_label(p: &fbgforge::model::GratingPrediction) -> String {
    format!(
        "{} Case {} {}",
        p.core,
        p.case,
        p.insert.as_deref().unwrap_or("")
    )
}

#[test]
fn on_the_shipped_designs_the_predicted_shift_per_newton_is_k() {
    // (c) The FE profiles of the shipped modules are nearly uniform along their 5 mm
    // gratings, so the transfer-matrix peak moves by K per newton (within 1 %), the
    // peak stays one clean peak over the force range and barely widens.
    for name in [
        "clip-on-10mm.toml",
        "clip-on-16mm.toml",
        "clip-on-22mm.toml",
        "clip-on-34mm.toml",
    ] {
        let d = common::shipped(name);
        let request = PredictionRequest {
            force_n: 10.0,
            design_interval: true,
            spectrum: true,
            cache: crate::fe_cache().clone(),
            ..PredictionRequest::default()
        };
        for (row, k, s) in spectra(&d, &request) {
            assert_eq!(s.strain_profile, ProfileSource::Fem, "{name} {row}");
            assert!(
                ((s.peak_shift_per_n_pm_per_n - k) / k).abs() < 0.01,
                "{name} {row}: {} pm/N from the spectrum vs K = {k} pm/N",
                s.peak_shift_per_n_pm_per_n
            );
            assert!(s.clean_over_range, "{name} {row}");
            assert!(s.fwhm_change_at_range_pct.abs() < 5.0, "{name} {row}");
        }
    }
}

#[test]
fn a_steep_gradient_over_a_long_grating_is_warned_with_the_force_where_it_stops() {
    // (d) Against clean_peak_limit run directly on the FE profile of the same
    // configuration, with a finer force grid than predict's eight steps.
    let d = common::long_grating_design();
    let request = PredictionRequest {
        force_n: 5.0,
        case: Some(LoadCase::II),
        core: Some("psc1".into()),
        fidelity: FidelityChoice::Fem,
        spectrum: true,
        cache: crate::fe_cache().clone(),
        ..PredictionRequest::default()
    };
    let rows = predict(&d, &request).unwrap();
    let row = rows
        .iter()
        .find(|r| r.detail.prediction.grating == "lambda_11")
        .unwrap();
    let s = row.spectrum.as_ref().unwrap();
    assert_eq!(s.force_range_n, 10.0);
    assert_eq!(s.force_range_from, "design");
    assert!(s.clean_unloaded && !s.clean_over_range);
    let f = s
        .clean_limit_force_n
        .expect("stops being clean inside 0–10 N");
    assert!(f > 0.0 && f < 10.0, "{f} N");
    let warned = row
        .detail
        .prediction
        .warnings
        .iter()
        .find(|w| w.contains("lambda_11") && w.contains("one clean peak"))
        .expect("the row is warned");
    assert!(warned.contains(&format!("{f:.3} N")), "{warned}");
    // The short gratings of the same core stay clean and are not warned.
    let short = rows
        .iter()
        .find(|r| r.detail.prediction.grating == "lambda_12")
        .unwrap();
    assert!(short.spectrum.as_ref().unwrap().clean_over_range);

    // Directly: the FE profile per newton of the design's reading, 40 forces over
    // the range.
    let m = d.module.as_ref().unwrap();
    let r = solve_configuration(
        &d,
        &config("psc1", LoadCase::II, None),
        &FemOptions::default().with_reading(m, ContactReading::Design, LoadCase::II),
        crate::fe_cache(),
    )
    .unwrap();
    let i = r
        .strain_per_n
        .iter()
        .position(|(n, _, _)| n == "lambda_11")
        .unwrap();
    let p = &r.strain_profile_per_n[i];
    let grating = d.bragg_grating("lambda_11").unwrap();
    let at = |force: f64| {
        StrainProfile::samples(p.z_mm.clone(), p.strain.iter().map(|e| e * force).collect())
            .unwrap()
    };
    let cases: Vec<SpectrumLoad> = (1..=40)
        .map(|k| {
            let force = 10.0 * f64::from(k) / 40.0;
            SpectrumLoad {
                force_n: force,
                strain: at(force),
            }
        })
        .collect();
    let criteria = CleanPeakCriteria::default();
    let direct = clean_peak_limit(&grating, &cases, &criteria)
        .unwrap()
        .force_n
        .unwrap();
    assert!(
        ((f - direct) / direct).abs() < 0.01,
        "predict {f} N vs clean_peak_limit {direct} N"
    );
    assert!(
        spectrum_shape(&grating, &at(0.98 * f), &criteria)
            .unwrap()
            .clean
    );
    assert!(
        !spectrum_shape(&grating, &at(1.02 * f), &criteria)
            .unwrap()
            .clean
    );
}

#[test]
fn predict_json_states_the_spectrum_with_units_in_its_names() {
    // (e) Every number of `spectrum` names its unit; flags and counts say what they are.
    let out = common::bin()
        .args(["predict", "--json", "--case", "II", "--no-band"])
        .arg(common::shipped_path("clip-on-34mm.toml"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["predictions"].as_array().unwrap();
    assert!(!rows.is_empty());
    let units = [
        "_pm",
        "_pm_per_n",
        "_n",
        "_pct",
        "_db",
        "_microstrain_per_n",
    ];
    let unitless = [
        "strain_profile",
        "profile_samples",
        "force_range_from",
        "lobes_at_range",
        "clean_unloaded",
        "clean_at_force",
        "clean_over_range",
    ];
    for r in rows {
        let s = r["spectrum"]
            .as_object()
            .expect("each row has its spectrum");
        assert_eq!(s.len(), 18, "{s:?}");
        for (key, value) in s {
            let with_unit = units.iter().any(|u| key.ends_with(u));
            assert!(
                with_unit || unitless.contains(&key.as_str()),
                "field `{key}` names no unit"
            );
            if with_unit {
                assert!(value.is_number() || value.is_null(), "{key}: {value}");
            }
        }
        // The 34 mm module's Case II rows are the closed form's; without the design
        // interval no FE solve ran for them, and the spectrum says its profile is uniform.
        assert_eq!(s["strain_profile"], "uniform-closed-form");
        assert!(s["clean_over_range"].as_bool().unwrap());
    }
    // `--no-spectrum` leaves it out.
    let out = common::bin()
        .args([
            "predict",
            "--json",
            "--case",
            "II",
            "--no-band",
            "--no-spectrum",
        ])
        .arg(common::shipped_path("clip-on-34mm.toml"))
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["predictions"][0].get("spectrum").is_none());
}

#[test]
fn build_warns_at_design_time_of_a_grating_that_stops_being_one_clean_peak() {
    // (f) The design-time check (`prediction::spectrum::design_warnings`, what `build`
    // and `optimize` run) names the grating, its configuration and the force where it
    // stops, the same force `predict` gives; the shipped module earns none.
    use fbgforge::prediction::spectrum::design_warnings;
    let d = common::long_grating_design();
    let warnings = design_warnings(&d, crate::fe_cache()).unwrap();
    let request = PredictionRequest {
        force_n: 10.0,
        fidelity: FidelityChoice::Fem,
        spectrum: true,
        refine_to_level: None,
        cache: crate::fe_cache().clone(),
        ..PredictionRequest::default()
    };
    let stops: Vec<(String, f64)> = predict(&d, &request)
        .unwrap()
        .iter()
        .filter_map(|r| {
            let f = r.spectrum.as_ref()?.clean_limit_force_n?;
            Some((config_label(&r.detail.prediction), f))
        })
        .collect();
    assert!(!stops.is_empty());
    assert_eq!(warnings.len(), stops.len(), "{warnings:#?}");
    for (config, f) in &stops {
        assert!(
            warnings.iter().any(|w| w.starts_with(config.trim_end())
                && w.contains("lambda_11")
                && w.contains(&format!("one clean peak at {f:.3} N"))),
            "{config} at {f} N not in {warnings:#?}"
        );
        assert!(*f > 0.0 && *f < 10.0, "{f} N");
    }
    // Case II of the 30 mm grating: 1.24 N in the last measurement.
    let case_ii = stops
        .iter()
        .find(|(c, _)| c.starts_with("psc1 Case II"))
        .unwrap();
    assert!(case_ii.1 > 0.5 && case_ii.1 < 3.0, "{stops:?}");
    assert!(
        design_warnings(&common::shipped("clip-on-34mm.toml"), crate::fe_cache())
            .unwrap()
            .is_empty()
    );

    // Through `build`'s sink: the table states it among the build's warnings.
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("long-grating.toml");
    std::fs::write(&spec, d.to_toml()).unwrap();
    let out = common::bin()
        .args(["build", "--parts", "cap", "--out"])
        .arg(dir.path().join("out"))
        .arg(&spec)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The table wraps long warnings at 80 columns: read it with its wraps joined.
    let raw = String::from_utf8_lossy(&out.stdout);
    let text = raw.split_whitespace().collect::<Vec<_>>().join(" ");
    let (_, f) = &stops[0];
    assert!(
        text.split("warning:")
            .skip(1)
            .any(|l| l.contains("lambda_11") && l.contains(&format!("{f:.3} N"))),
        "{text}"
    );
}
