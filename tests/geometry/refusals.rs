//! Spec rules of issue 39, point 2: two gratings on one fiber keep their lengths plus
//! `GRATING_END_GAP_MM` apart, and every refusal names the field (or the option) and the
//! range that would work, with both rules named when two rules cross. Each case is
//! checked on both sides of its edge: the refused value and one the message allows.

use crate::common::{shipped, shipped_path};
use fbgforge::spec::{Design, ModuleGrating, GRATING_END_GAP_MM};

/// The first `allowed A to B mm` range in a message (the first interval of it).
fn allowed_range(e: &str) -> (f64, f64) {
    let rest = e
        .split("allowed ")
        .nth(1)
        .unwrap_or_else(|| panic!("no range in: {e}"));
    let mut w = rest.split_whitespace();
    let lo: f64 = w.next().unwrap().parse().unwrap();
    assert_eq!(w.next(), Some("to"), "{e}");
    let hi: f64 = w
        .next()
        .unwrap()
        .trim_end_matches(|c: char| !c.is_ascii_digit())
        .parse()
        .unwrap();
    (lo, hi)
}

fn refusal(d: &Design) -> String {
    d.validate().expect_err("refused").to_string()
}

#[test]
fn two_module_gratings_on_one_pillar_must_not_overlap() {
    let d0 = shipped("clip-on-34mm.toml");
    let mut d = d0.clone();
    let m = d.module.as_mut().unwrap();
    let first: ModuleGrating = m.gratings[0].clone();
    let mut twin = first.clone();
    twin.name = "lambda_11b".into();
    twin.bragg_wavelength_nm += 10.0;
    m.gratings.push(twin);
    let i = m.gratings.len() - 1;
    let e = refusal(&d);
    assert!(
        e.contains(&format!("module.gratings[{i}].center_height_mm"))
            && e.contains("lambda_11")
            && e.contains("overlap by 5.000 mm"),
        "{e}"
    );
    // The range the message gives works at its ends (inside them by a hair), and a
    // centre just short of the end gap does not.
    let (lo, hi) = allowed_range(&e);
    for c in [lo + 1e-3, hi - 1e-3] {
        let mut ok = d.clone();
        ok.module.as_mut().unwrap().gratings[i].center_height_mm = Some(c);
        ok.validate().unwrap_or_else(|e| panic!("{c}: {e}"));
    }
    let c0 = first.center_height_mm.unwrap();
    let near = c0 + first.length_mm + GRATING_END_GAP_MM - 0.01;
    let mut close = d.clone();
    close.module.as_mut().unwrap().gratings[i].center_height_mm = Some(near);
    assert!(refusal(&close).contains("only 0.990 mm apart"));
    // On another pillar of the same core the same place is another fiber: accepted.
    let mut other = d.clone();
    other.module.as_mut().unwrap().gratings[i].pillar = Some(2);
    other.validate().unwrap();
}

#[test]
fn two_array_gratings_on_one_fiber_must_not_overlap() {
    let mut d = shipped("tactile-array-60x80.toml");
    let a = d.array.as_mut().unwrap();
    let mut twin = a.gratings[0].clone();
    twin.name = "fbg1b".into();
    twin.bragg_wavelength_nm += 20.0;
    twin.y_mm += 2.0;
    a.gratings.push(twin);
    let i = a.gratings.len() - 1;
    let e = refusal(&d);
    assert!(
        e.contains(&format!("array.gratings[{i}].y_mm")) && e.contains("fbg1"),
        "{e}"
    );
    // 3 mm gratings keep 3 + 1 mm between centres: 12.5 + 4 = 16.5 is the edge.
    for (y, ok) in [(16.49, false), (16.5, true), (-12.5, true)] {
        let mut t = d.clone();
        t.array.as_mut().unwrap().gratings[i].y_mm = y;
        assert_eq!(t.validate().is_ok(), ok, "{y}: {:?}", t.validate());
    }
}

#[test]
fn a_sheet_too_thin_for_its_fiber_seat_names_the_thickness_and_the_least_that_works() {
    // Issue 39: a 0.3 mm sheet failed inside the mesher ("mesh check `closed`").
    let text = std::fs::read_to_string(shipped_path("tactile-array-60x80.toml")).unwrap();
    let at = |t: f64| {
        let s = text
            .replacen("thickness_mm = 5.0", &format!("thickness_mm = {t}"), 1)
            .replacen("wall_height_mm = 5.0", "wall_height_mm = 1.0", 1)
            .replacen("plugs = true", "plugs = false", 1);
        fbgforge::design::parse(&s).map_err(|e| e.to_string())
    };
    let e = at(0.3).unwrap_err();
    eprintln!("0.3 mm sheet: {e}");
    assert!(
        e.contains("array.thickness_mm") && e.contains("allowed above"),
        "{e}"
    );
    let least: f64 = e
        .split("allowed above ")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(least > 0.3 && least < 0.8, "{e}");
    // Just above the least the message names, the sheet builds into a closed mold.
    let d = at(least + 0.01).unwrap_or_else(|e| panic!("{e}"));
    let parts = fbgforge::geometry::build_parts(&d, None, None).unwrap();
    assert!(!parts.is_empty());
    assert!(at(least - 0.01).is_err());
}

#[test]
fn two_rules_that_cannot_both_be_met_are_named_together() {
    // Issue 39: a held-out design got two pillar-height messages whose ranges could not
    // both be met. A groove so deep that the pillar must be taller than 0.3 R: one
    // message, naming both rules and their fields.
    let mut d = shipped("clip-on-10mm.toml");
    d.module.as_mut().unwrap().pillars.groove_depth_mm = 1.0;
    let e = refusal(&d);
    eprintln!("{e}");
    assert!(
        e.contains("module.pillars.height_mm")
            && e.contains("two rules conflict")
            && e.contains("module.pillars.groove_depth_mm")
            && e.contains("module.outer_diameter_mm"),
        "{e}"
    );
    // Either way out works: a shallower groove, or a module wide enough.
    let mut shallow = d.clone();
    shallow.module.as_mut().unwrap().pillars.groove_depth_mm = 0.2;
    let msg = shallow
        .validate()
        .map_or_else(|e| e.to_string(), |()| String::new());
    assert!(!msg.contains("two rules conflict"), "{msg}");
}
