//! Additivity (Figs. 6–8): loads alone, then together. On a linear sheet the
//! simultaneous reading is the sum of the single ones (error within noise, nothing
//! significant); the table's CSV and the stacked-bar SVG are written beside it.

use crate::calibrate_runs::{analysed, lab, truth};
use fbgforge::array::calibrate::Loading;

fn on(start_s: f64, cell: usize, load_g: f64) -> Loading {
    Loading {
        start_s,
        end_s: start_s + 10.0,
        cell,
        load_g,
    }
}

#[test]
fn a_linear_sheet_adds_up_and_the_table_and_chart_are_written() {
    let a = truth();
    // A alone, B alone, then A and B together; 100 g each; twice.
    let mut ev = Vec::new();
    for r in 0..2 {
        let t = 10.0 + 60.0 * f64::from(r);
        ev.push(on(t, 0, 100.0));
        ev.push(on(t + 20.0, 1, 100.0));
        ev.push(on(t + 40.0, 0, 100.0));
        ev.push(on(t + 40.0, 1, 100.0));
    }
    let c = analysed(&a, &ev, &ev, &lab());
    assert!(
        c.faults
            .iter()
            .all(|f| f.severity != fbgforge::array::calibrate::Severity::Unusable),
        "{:#?}",
        c.faults
    );
    assert_eq!(c.additivity.len(), 1, "{:#?}", c.additivity);
    let t = &c.additivity[0];
    assert_eq!(
        (t.cells.clone(), t.loads_g.clone(), t.repeats),
        (
            vec!["A".to_string(), "B".to_string()],
            vec![100.0, 100.0],
            2
        )
    );
    for (g, r) in t.gratings.iter().enumerate() {
        // Each single response is the true entry × 100 g, the sum adds up.
        for (k, cell) in [0, 1].iter().enumerate() {
            let want = 100.0 * a.sensitivity_pm_per_g[(g, *cell)];
            assert!(
                (r.individual_pm[k] - want).abs() < 0.3,
                "{} {cell}: {} vs {want}",
                r.grating,
                r.individual_pm[k]
            );
        }
        assert!((r.sum_pm - r.individual_pm.iter().sum::<f64>()).abs() < 1e-9);
        assert!(
            !r.significant
                && (r.simultaneous_pm - r.sum_pm).abs() < 4.0 * r.difference_sem_pm.max(0.1),
            "{r:?}"
        );
    }
    // The CSV and the stacked bars beside the matrix's path.
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("A.csv");
    let written = fbgforge::report::calibrate::charts::write_charts(&c, &stem).unwrap();
    assert!(
        written.contains(&dir.path().join("A.additivity.csv"))
            && written.contains(&dir.path().join("A.additivity.svg")),
        "{written:?}"
    );
    let csv = std::fs::read_to_string(dir.path().join("A.additivity.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 6, "{csv}");
    assert!(std::fs::read_to_string(dir.path().join("A.additivity.svg"))
        .unwrap()
        .starts_with("<svg"));
}
