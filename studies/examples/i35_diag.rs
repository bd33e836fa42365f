use fbgforge::array::methods::{Method, ReadingSettings};
use fbgforge::array::reconstruct::{reconstruct, Frames, MethodRequest};
use fbgforge_studies::reconstruct_flags::gen::{arrays, stream, Fault};
use fbgforge::array::problem::{SensingProblem, Uncertainty, PAPER_MIN_LOAD_G};
use rayon::prelude::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let ai: usize = args[1].parse().unwrap();
    let streams: u64 = args[2].parse().unwrap();
    let only: Option<&str> = args.get(3).map(|s| s.as_str());
    let arr = &arrays(false)[ai];
    for fault in Fault::ALL {
        if only.is_some_and(|o| o != fault.name()) { continue; }
        let lines: Vec<String> = (0..streams).into_par_iter().map(|s| {
            let st = stream(arr, fault, 200, 7000 + s);
            let (m, n) = st.matrix.shape();
            let mut unc = Uncertainty::paper(m, n, st.resolution_pm);
            if let Some(p) = st.matrix_sd_pct { unc.matrix_sd_pm_per_g = st.matrix.map(|v| v.abs() * p / 100.0); }
            let p = SensingProblem::new(st.matrix.clone(), 250.0, true).unwrap().with_min_load_g(PAPER_MIN_LOAD_G).unwrap().with_uncertainty(unc).unwrap();
            let prior = ReadingSettings { max_loads: 4, resolution_pm: st.resolution_pm };
            let names: Vec<String> = (1..=m).map(|i| format!("g{}", i - 1)).collect();
            let t = std::time::Instant::now();
            let d = reconstruct(&p, Frames { gratings: &names, shifts_pm: &st.shifts_pm }, &prior, &MethodRequest::named(Method::BranchAndBound), &fbgforge::progress::Quiet).unwrap();
            let sus: Vec<String> = d.suspect_gratings.iter().map(|s| format!("{}:{}{} [{}]", s.name, s.reason.words(), s.partner_name.as_ref().map_or(String::new(), |p| format!("~{p}")), s.evidence)).collect();
            format!("  s{} sigma {} expect {:?} → cm {} suspects {:?} ({:.1}s) | {}", s, st.resolution_pm, st.expect, d.diagnosis.common_mode.fitted, sus, t.elapsed().as_secs_f64(), d.diagnosis.common_mode.reason)
        }).collect();
        println!("{} {}", arr.name, fault.name());
        for l in lines { println!("{l}"); }
    }
}
