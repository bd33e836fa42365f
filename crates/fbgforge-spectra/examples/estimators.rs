//! Speed against accuracy of the peak estimators.
//!
//! For SNR 30, 300, 3000 and FWHM 1, 1.5, 2, 3, 6 samples: many noisy realisations of a
//! Gaussian peak (amplitude 1, floor 10σ, white noise σ = 1/SNR, centre uniformly random
//! within a sample, 8 pm pitch), each estimator run on the finder's window (±2 FWHM, at
//! least 5 samples each side, floor from the outer samples, σ from the robust
//! estimate). RMS error / CRB is √(mean err²) / √(mean CRB²), the CRB evaluated on each
//! window's grid at the true centre, width and amplitude. Time per peak is the
//! estimator alone (windows and templates prepared beforehand).
//!
//! `cargo run -p fbgforge-spectra --release --example estimators -- [OUT.csv] [REALISATIONS]`

use std::time::Instant;

use fbgforge_spectra::peaks::{
    gaussian_position_crb_joint_pm, gaussian_position_crb_pm, Centroid, GaussianLeastSquares,
    Parabola, PeakEstimator, PeakWindow, Template, TemplateMatch,
};
use fbgforge_spectra::stats::noise_sigma_mad_diff;
use fbgforge_spectra::synth::SynthSpectrum;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const PITCH_NM: f64 = 0.008;
const SNRS: [f64; 3] = [30.0, 300.0, 3000.0];
const FWHMS: [f64; 5] = [1.0, 1.5, 2.0, 3.0, 6.0];

struct Case {
    wavelengths: Vec<f64>,
    power: Vec<f64>,
    range: std::ops::Range<usize>,
    max_index: usize,
    sigma: f64,
    center: f64,
    crb_pm: f64,
    crb_joint_pm: f64,
}

fn case(snr: f64, fwhm_samples: f64, rng: &mut ChaCha8Rng, seed: u64) -> Case {
    let center = 1550.0 + PITCH_NM * rng.random_range(-0.5..0.5);
    let synth = SynthSpectrum::gaussian_case(center, fwhm_samples, PITCH_NM, snr);
    let s = synth.spectrum(seed);
    let sigma = noise_sigma_mad_diff(&s.power);
    let (w, p) = (s.wavelengths_nm, s.power);
    // The finder's window: candidate = highest sample near the centre.
    let near = w.partition_point(|&x| x < center - 2.0 * fwhm_samples * PITCH_NM);
    let far = w.partition_point(|&x| x <= center + 2.0 * fwhm_samples * PITCH_NM);
    let max_index = (near..far)
        .max_by(|&a, &b| p[a].total_cmp(&p[b]))
        .unwrap_or(near);
    let half = 2.0 * fwhm_samples * PITCH_NM;
    let lo = w
        .partition_point(|&x| x < w[max_index] - half)
        .min(max_index - 5);
    let hi = w
        .partition_point(|&x| x <= w[max_index] + half)
        .max(max_index + 6);
    let crb_pm =
        gaussian_position_crb_pm(&w[lo..hi], center, fwhm_samples * PITCH_NM, 1.0, 1.0 / snr);
    let crb_joint_pm =
        gaussian_position_crb_joint_pm(&w[lo..hi], center, fwhm_samples * PITCH_NM, 1.0, 1.0 / snr);
    Case {
        wavelengths: w,
        power: p,
        range: lo..hi,
        max_index,
        sigma,
        center,
        crb_pm,
        crb_joint_pm,
    }
}

struct Row {
    estimator: &'static str,
    snr: f64,
    fwhm_samples: f64,
    rms_pm: f64,
    bias_pm: f64,
    crb_pm: f64,
    crb_joint_pm: f64,
    failures: usize,
    time_us: f64,
}

fn templates(fwhm_samples: f64, rng: &mut ChaCha8Rng) -> TemplateMatch {
    // The grating's unloaded spectrum: the same shape on the same pitch, noiseless, at
    // an arbitrary sub-sample position (as a measured reference would be).
    let reference = 1550.0 + PITCH_NM * rng.random_range(-0.5..0.5);
    let half = (5.0 * fwhm_samples).ceil() as usize + 5;
    let synth = SynthSpectrum::gaussian_case(reference, fwhm_samples, PITCH_NM, 1e12);
    let t = synth.truth().expect("template");
    let k = synth.wavelengths_nm.len() / 2;
    let template = Template::new(
        synth.wavelengths_nm[k - half..=k + half].to_vec(),
        t[k - half..=k + half].to_vec(),
    )
    .expect("template");
    TemplateMatch {
        templates: vec![template],
    }
}

fn measure(estimator: &dyn PeakEstimator, cases: &[Case], snr: f64, fwhm_samples: f64) -> Row {
    let windows: Vec<PeakWindow> = cases
        .iter()
        .map(|c| {
            PeakWindow::new(
                &c.wavelengths,
                &c.power,
                c.range.clone(),
                c.max_index,
                1.5 * fwhm_samples * PITCH_NM,
                10.0 / snr,
                c.sigma,
            )
            .expect("window")
        })
        .collect();
    let start = Instant::now();
    let estimates: Vec<_> = windows.iter().map(|w| estimator.estimate(w)).collect();
    let time_us = 1e6 * start.elapsed().as_secs_f64() / cases.len() as f64;
    let mut errors = Vec::new();
    let (mut crb2, mut joint2) = (0.0, 0.0);
    for (c, e) in cases.iter().zip(&estimates) {
        if let Ok(e) = e {
            errors.push(1e3 * (e.wavelength_nm - c.center));
            crb2 += c.crb_pm * c.crb_pm;
            joint2 += c.crb_joint_pm * c.crb_joint_pm;
        }
    }
    let n = errors.len().max(1) as f64;
    Row {
        estimator: estimator.name(),
        snr,
        fwhm_samples,
        rms_pm: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
        bias_pm: errors.iter().sum::<f64>() / n,
        crb_pm: (crb2 / n).sqrt(),
        crb_joint_pm: (joint2 / n).sqrt(),
        failures: cases.len() - errors.len(),
        time_us,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = args
        .get(1)
        .cloned()
        .unwrap_or_else(|| "target/spectra-estimators.csv".into());
    let realisations: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(2000);
    let mut rng = ChaCha8Rng::seed_from_u64(36);
    let mut rows = Vec::new();
    for &snr in &SNRS {
        for &fwhm in &FWHMS {
            let cases: Vec<Case> = (0..realisations)
                .map(|k| case(snr, fwhm, &mut rng, 1000 * k as u64 + 7))
                .collect();
            let xcorr = templates(fwhm, &mut rng);
            let estimators: [&dyn PeakEstimator; 4] = [
                &GaussianLeastSquares,
                &Parabola::default(),
                &Centroid::default(),
                &xcorr,
            ];
            for e in estimators {
                rows.push(measure(e, &cases, snr, fwhm));
            }
        }
    }
    print_table(&rows, realisations);
    let default = choose_default(&rows);
    println!("\ndefault estimator: {default} (the cheapest whose RMS error stays within 2× the CRB wherever some estimator does)");
    let mut csv = String::from("estimator,snr,fwhm_samples,rms_error_pm,bias_pm,crb_pm,crb_joint_pm,rms_over_crb,rms_over_crb_joint,failures,time_per_peak_us\n");
    for r in &rows {
        csv.push_str(&format!(
            "{},{},{},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{},{:.3}\n",
            r.estimator,
            r.snr,
            r.fwhm_samples,
            r.rms_pm,
            r.bias_pm,
            r.crb_pm,
            r.crb_joint_pm,
            r.rms_pm / r.crb_pm,
            r.rms_pm / r.crb_joint_pm,
            r.failures,
            r.time_us
        ));
    }
    match std::fs::write(&out, csv) {
        Ok(()) => println!("wrote {out}"),
        Err(e) => eprintln!("could not write {out}: {e}"),
    }
}

fn print_ratio_table(rows: &[Row], bound: &dyn Fn(&Row) -> f64, with_time: bool) {
    print!("| estimator |{}", if with_time { " µs/peak |" } else { "" });
    for snr in SNRS {
        for f in FWHMS {
            print!(" {snr}/{f} |");
        }
    }
    println!();
    println!(
        "|---|{}{}",
        if with_time { "---|" } else { "" },
        "---|".repeat(SNRS.len() * FWHMS.len())
    );
    for name in ["gaussian", "parabola", "centroid", "xcorr"] {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.estimator == name).collect();
        let time = mine.iter().map(|r| r.time_us).sum::<f64>() / mine.len() as f64;
        print!("| {name} |");
        if with_time {
            print!(" {time:.2} |");
        }
        for r in &mine {
            if r.failures > 0 {
                print!(" {:.2} ({}) |", r.rms_pm / bound(r), r.failures);
            } else {
                print!(" {:.2} |", r.rms_pm / bound(r));
            }
        }
        println!();
    }
}

fn print_table(rows: &[Row], realisations: usize) {
    println!("{realisations} realisations per cell, pitch {} pm; columns SNR/FWHM in samples; failures in brackets\n", 1e3 * PITCH_NM);
    println!("RMS error / CRB (position-only bound, the `crb_pm` of each peak):\n");
    print_ratio_table(rows, &|r| r.crb_pm, true);
    println!("\nRMS error / joint CRB (amplitude, width and floor unknown too):\n");
    print_ratio_table(rows, &|r| r.crb_joint_pm, false);
    println!("\nCRB, position-only / joint (pm):");
    for snr in SNRS {
        let line: Vec<String> = FWHMS
            .iter()
            .map(|&f| {
                let r = rows
                    .iter()
                    .find(|r| r.snr == snr && r.fwhm_samples == f)
                    .expect("row");
                format!("{f}: {:.4}/{:.4}", r.crb_pm, r.crb_joint_pm)
            })
            .collect();
        println!("  SNR {snr}: {}", line.join(", "));
    }
}

fn choose_default(rows: &[Row]) -> &'static str {
    let mut names: Vec<(&'static str, f64)> = ["gaussian", "parabola", "centroid", "xcorr"]
        .iter()
        .map(|&n| {
            let t: Vec<f64> = rows
                .iter()
                .filter(|r| r.estimator == n)
                .map(|r| r.time_us)
                .collect();
            (n, t.iter().sum::<f64>() / t.len() as f64)
        })
        .collect();
    names.sort_by(|a, b| a.1.total_cmp(&b.1));
    let ratio = |r: &Row| {
        if r.failures > 0 {
            f64::INFINITY
        } else {
            r.rms_pm / r.crb_pm
        }
    };
    for (name, _) in names {
        let ok = SNRS.iter().all(|&snr| {
            FWHMS.iter().all(|&f| {
                let cell: Vec<&Row> = rows
                    .iter()
                    .filter(|r| r.snr == snr && r.fwhm_samples == f)
                    .collect();
                let attainable = cell.iter().any(|r| ratio(r) <= 2.0);
                let mine = cell
                    .iter()
                    .find(|r| r.estimator == name)
                    .map(|r| ratio(r))
                    .unwrap_or(f64::INFINITY);
                !attainable || mine <= 2.0
            })
        });
        if ok {
            return name;
        }
    }
    "gaussian"
}
