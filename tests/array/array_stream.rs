//! Issue 35: `reconstruct` from a file streams it (docs/array.md §11.10): the frames
//! held at once do not grow with the file, and what it writes is exactly what the
//! in-memory reconstruction of the same frames gives (the stream diagnosis
//! included: a dead grating is named and left out alike).

use fbgforge::array::kernel::{matrix_from_positions, paper_layout, DistanceKernel};
use fbgforge::array::methods::{Method, ReadingSettings};
use fbgforge::array::problem::{default_min_load_g, SensingProblem};
use fbgforge::array::reconstruct::{reconstruct, Frames, MethodRequest, CHUNK_FRAMES};
use fbgforge::array::run::{reconstruct_file, MatrixSource, ReconstructRequest};
use fbgforge::progress::Quiet;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::fmt::Write as _;
use std::path::Path;

/// The paper's 6 × 8 array.
fn paper() -> DMatrix<f64> {
    let (c, g) = paper_layout();
    matrix_from_positions(&c, &g, &DistanceKernel::paper())
}

/// `frames` frames of 1–3 loads of 50–220 g, 0.5 pm noise, grating fbg3 dead
/// (reading nothing) throughout.
fn frames(a: &DMatrix<f64>, frames: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.5).unwrap();
    (0..frames)
        .map(|f| {
            let mut x = DVector::zeros(a.ncols());
            for _ in 0..1 + f % 3 {
                x[rng.random_range(0..a.ncols())] = rng.random_range(50.0..220.0);
            }
            let mut y: Vec<f64> = (a * x).iter().map(|v| v + noise.sample(&mut rng)).collect();
            y[2] = 0.0;
            y
        })
        .collect()
}

fn write_files(
    dir: &Path,
    a: &DMatrix<f64>,
    ys: &[Vec<f64>],
) -> (std::path::PathBuf, std::path::PathBuf) {
    let mut m = String::from("grating,A,B,C,D,E,F,G,H\n");
    for i in 0..a.nrows() {
        let row: Vec<String> = a.row(i).iter().map(|v| format!("{v:e}")).collect();
        writeln!(m, "fbg{},{}", i + 1, row.join(",")).unwrap();
    }
    let mut s = String::from("time_s,fbg1,fbg2,fbg3,fbg4,fbg5,fbg6\n");
    for (k, y) in ys.iter().enumerate() {
        let row: Vec<String> = y.iter().map(|v| format!("{v:e}")).collect();
        writeln!(s, "{},{}", k as f64 * 1e-3, row.join(",")).unwrap();
    }
    let (mp, sp) = (dir.join("A.csv"), dir.join("shifts.csv"));
    std::fs::write(&mp, m).unwrap();
    std::fs::write(&sp, s).unwrap();
    (mp, sp)
}

#[test]
fn reconstruct_file_holds_a_bounded_number_of_frames_and_writes_what_memory_gives() {
    let a = paper();
    let dir = tempfile::tempdir().unwrap();
    let mut held = Vec::new();
    for n in [3 * CHUNK_FRAMES + 17, 12 * CHUNK_FRAMES + 5] {
        let ys = frames(&a, n, 35 + n as u64);
        let (mp, sp) = write_files(dir.path(), &a, &ys);
        let mut req = ReconstructRequest::new(MatrixSource::Csv(mp), sp);
        req.method = Some("bnb".into());
        req.out = Some(dir.path().join("loads.csv"));
        let s = reconstruct_file(&req, &Quiet).unwrap();
        assert_eq!(s.frames, n);
        held.push(s.most_frames_held);
        // The dead grating is named in the stream as in memory.
        let names: Vec<String> = (1..=6).map(|i| format!("fbg{i}")).collect();
        // The problem the file run states: the paper's 25–250 g range.
        let problem = SensingProblem::new(a.clone(), 250.0, true)
            .unwrap()
            .with_min_load_g(default_min_load_g(250.0))
            .unwrap();
        let mem = reconstruct(
            &problem,
            Frames {
                gratings: &names,
                shifts_pm: &ys,
            },
            &ReadingSettings::paper(),
            &MethodRequest::named(Method::BranchAndBound),
            &Quiet,
        )
        .unwrap();
        let named: Vec<&str> = s.suspect_gratings.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(named, ["fbg3"], "{:?}", s.suspect_gratings);
        assert_eq!(
            format!("{:?}", s.suspect_gratings),
            format!("{:?}", mem.suspect_gratings)
        );
        // Row by row, the file holds the in-memory answers (3 decimals as written).
        let text = std::fs::read_to_string(dir.path().join("loads.csv")).unwrap();
        let rows: Vec<&str> = text.lines().skip(1).collect();
        assert_eq!(rows.len(), n);
        for (k, (line, r)) in rows.iter().zip(&mem.frames).enumerate() {
            let fields: Vec<&str> = line.split(',').collect();
            for (j, want) in r.loads_g.iter().enumerate() {
                let got: f64 = fields[1 + j].parse().unwrap();
                assert!(
                    (got - want).abs() < 1e-3,
                    "frame {k} cell {j}: {got} vs {want}"
                );
            }
            assert_eq!(fields[10], r.flags.field(), "frame {k}");
        }
        assert_eq!(s.flags.trusted, mem.flag_counts.trusted);
    }
    // One chunk of the file and the diagnosis's bounded sample (≤ 2 × (48 + 48 + 32
    // per grating)), the same for 3 and 12 chunks' worth of frames.
    assert!(held[0] <= CHUNK_FRAMES + 2 * (48 + 48 + 32 * 6), "{held:?}");
    assert_eq!(held[0], held[1], "{held:?}");
}

#[test]
fn a_bad_row_past_the_first_chunk_is_named_and_nothing_is_written() {
    let a = paper();
    let dir = tempfile::tempdir().unwrap();
    let ys = frames(&a, 2 * CHUNK_FRAMES, 7);
    let (mp, sp) = write_files(dir.path(), &a, &ys);
    let mut text = std::fs::read_to_string(&sp).unwrap();
    text.push_str("9.9,1,2,x,4,5,6\n");
    std::fs::write(&sp, text).unwrap();
    let mut req = ReconstructRequest::new(MatrixSource::Csv(mp), sp);
    req.method = Some("nnls".into());
    let out = dir.path().join("loads.csv");
    req.out = Some(out.clone());
    let e = format!("{:#}", reconstruct_file(&req, &Quiet).unwrap_err());
    let line = 2 * CHUNK_FRAMES + 2;
    assert!(
        e.contains(&format!("shifts.csv:{line}")) && e.contains("fbg3") && e.contains("`x`"),
        "{e}"
    );
    assert!(!out.exists());
}
