//! The contact as a family rule: the shipped designs state their contact relative to
//! the features it scales with and keep their predictions; a module interpolated at
//! every whole millimetre from 10 to 22 mm (the paper's range) keeps the paper's Case I
//! statements with the default contact reading and the shipped materials, and a
//! statement that fails is named, per design.

use crate::common;
use fbgforge::model::LoadCase;
use fbgforge::prediction::{self, check_paper_statements, PredictionRequest};
use fbgforge::spec::{Design, Insert};

const SHIPPED: [&str; 4] = [
    "clip-on-10mm.toml",
    "clip-on-16mm.toml",
    "clip-on-22mm.toml",
    "clip-on-34mm.toml",
];

/// The design with every insert the material library offers its printer (the shipped
/// materials), besides its own.
fn with_library_inserts(d: &Design) -> Design {
    use fbgforge::optimize::materials::{MaterialLibrary, MaterialRole};
    let lib = MaterialLibrary::shipped();
    let mut d = d.clone();
    let keys = lib.for_role(MaterialRole::Insert, d.printer.process);
    for key in keys {
        let m = d.module.as_mut().unwrap();
        if m.inserts.iter().any(|i| i.material == key) {
            continue;
        }
        m.inserts.push(Insert {
            name: key.clone(),
            material: key.clone(),
        });
        let spec = lib.materials[&key].to_spec_material();
        d.materials.insert(key, spec);
    }
    d.validate().unwrap();
    d
}

/// The policy's rows a statement check needs: Case I on the first core (every
/// insert), Case II on every core (the closed form: no FE solve).
fn statement_rows(d: &Design) -> Vec<prediction::ModelledPrediction> {
    let m = d.module.as_ref().unwrap();
    let mut rows = prediction::predict(
        d,
        &PredictionRequest {
            case: Some(LoadCase::I),
            core: Some(m.cores[0].name.clone()),
            ..Default::default()
        },
    )
    .unwrap();
    rows.extend(
        prediction::predict(
            d,
            &PredictionRequest {
                case: Some(LoadCase::II),
                ..Default::default()
            },
        )
        .unwrap(),
    );
    rows
}

#[test]
fn shipped_designs_state_their_contact_relative_and_keep_their_radius() {
    // Before the family rule the shipped files gave the contact in mm, the radius as
    // 1.376 × the apex patch rounded to the micrometre; each file now gives the ratio.
    for (file, radius_mm, clip_mm, clearance_mm) in [
        ("clip-on-10mm.toml", 0.688, 0.6, 0.05),
        ("clip-on-16mm.toml", 1.032, 0.9, 0.08),
        ("clip-on-22mm.toml", 1.307, 1.1, 0.1),
        ("clip-on-34mm.toml", 1.72, 1.5, 0.1),
    ] {
        let d = common::shipped(file);
        let m = d.module.as_ref().unwrap();
        let c = &m.contact;
        assert!(
            c.dome_contact_radius_mm.is_none()
                && c.clip_height_mm.is_none()
                && c.dome_clearance_mm.is_none(),
            "{file}: a contact length in mm"
        );
        assert_eq!(c.dome_contact_radius_to_patch, Some(1.376), "{file}");
        assert!(
            (m.dome_contact_radius_mm() - radius_mm).abs() <= 5e-4,
            "{file}: {} mm",
            m.dome_contact_radius_mm()
        );
        assert!((m.clip_height_mm() - clip_mm).abs() < 1e-12, "{file}");
        assert!(
            (m.dome_clearance_mm() - clearance_mm).abs() < 1e-12,
            "{file}"
        );
        assert!(m.contact_radius_is_default(), "{file}");
    }
}

#[test]
fn the_family_keeps_the_contact_ratio_where_the_old_rule_scaled_the_radius_with_d() {
    let knots: Vec<Design> = SHIPPED[..3].iter().map(|f| common::shipped(f)).collect();
    for dia in [10.0, 12.5, 16.0, 19.0, 22.0] {
        let d = fbgforge::family::interpolate(&knots, dia).unwrap();
        let m = d.module.as_ref().unwrap();
        let r = m.dome_contact_radius_mm() / m.apex_patch_radius_mm();
        assert!((r - 1.376).abs() < 1e-12, "{dia} mm: ratio {r}");
        assert!((m.clip_height_mm() / m.cap_wall_mm - 1.0).abs() < 1e-12);
    }
    // The paper's module scaled to 16 mm with the printer's thinnest cap (0.3 mm) is
    // the case: the apex patch shrinks to well below D/34 of the 34 mm one, and
    // the radius follows it, not the diameter.
    let base = common::shipped("clip-on-34mm.toml");
    let d = fbgforge::family::scaled_design(&base, 16.0, 0.3).unwrap();
    let m = d.module.as_ref().unwrap();
    assert!(
        (m.dome_contact_radius_mm() / m.apex_patch_radius_mm() - 1.376).abs() < 1e-12,
        "{}",
        m.dome_contact_radius_mm()
    );
    assert!(m.dome_contact_radius_mm() < 1.72 * 16.0 / 34.0);
    // A sweep of the cap wall carries the ratio too, even from a design in mm.
    let mut mm = base.clone();
    let mb = mm.module.as_mut().unwrap();
    mb.contact.dome_contact_radius_to_patch = None;
    mb.contact.dome_contact_radius_mm = Some(1.72);
    let swept = fbgforge::model::sweep::with_param(
        &mm,
        fbgforge::model::sweep::find_param("cap_wall_mm").unwrap(),
        1.0,
    )
    .unwrap();
    let ms = swept.module.as_ref().unwrap();
    assert!((ms.dome_contact_radius_mm() - 1.376 * (0.5 + 0.5)).abs() < 1e-9);
}

#[test]
fn every_whole_millimetre_from_10_to_22_keeps_the_papers_case_i_statements() {
    let knots: Vec<Design> = SHIPPED[..3].iter().map(|f| common::shipped(f)).collect();
    let mut failures = Vec::new();
    let mut table = Vec::new();
    for mm in 10..=22 {
        let d = with_library_inserts(&fbgforge::family::interpolate(&knots, mm as f64).unwrap());
        let rows = statement_rows(&d);
        // Every Case I row says its contact was chosen, not measured.
        for r in rows
            .iter()
            .filter(|r| r.detail.prediction.case == LoadCase::I)
        {
            assert!(
                r.detail
                    .prediction
                    .warnings
                    .iter()
                    .any(|w| w == prediction::DEFAULT_CONTACT_WARNING),
                "{mm} mm: {:?}",
                r.detail.prediction.warnings
            );
        }
        let s = check_paper_statements(&d, &rows).unwrap();
        assert_eq!(s.checks.len(), 3);
        for c in &s.checks {
            assert!(c.holds.is_some(), "{mm} mm: {} not checked", c.statement);
        }
        table.push(format!("{mm} mm: {}", s.summary()));
        for f in s.failures() {
            failures.push(format!("{mm} mm: {} fails ({})", f.statement, f.detail));
        }
    }
    // The table of every size (shown with --nocapture).
    eprintln!("{}", table.join("\n"));
    assert!(
        failures.is_empty(),
        "statements that fail:\n{}\nall:\n{}",
        failures.join("\n"),
        table.join("\n")
    );
}

#[test]
fn a_contact_outside_the_window_fails_a_statement_and_says_which() {
    // The optimised 16 mm module: the contact radius 2.44 × the apex patch
    // (the old rule scaled it with D while the patch shrank): Case I turns blue.
    let d = prediction::with_contact_ratio(&common::shipped("clip-on-16mm.toml"), 2.44);
    let rows = statement_rows(&d);
    let s = check_paper_statements(&d, &rows).unwrap();
    let failed: Vec<&str> = s.failures().iter().map(|c| c.statement).collect();
    assert!(!failed.is_empty(), "{}", s.summary());
    assert!(
        s.summary().contains("FAILS"),
        "the summary names the failure: {}",
        s.summary()
    );
    // Not the default contact: no "chosen, not measured" warning.
    assert!(rows.iter().all(|r| !r
        .detail
        .prediction
        .warnings
        .iter()
        .any(|w| w == prediction::DEFAULT_CONTACT_WARNING)));
}
