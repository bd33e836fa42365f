use fbgforge::array::methods::{Method, ReadingSettings};
use fbgforge::array::reconstruct::{prepare, MethodRequest};
use fbgforge_studies::reconstruct_flags::gen::{arrays, stream, Fault};
use fbgforge::array::problem::{SensingProblem, Uncertainty, PAPER_MIN_LOAD_G};
use fbgforge::array::protocol::snr_db;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let ai: usize = args[1].parse().unwrap();
    let seed: u64 = args[2].parse().unwrap();
    let arr = &arrays(false)[ai];
    let st = stream(arr, Fault::Clean, 200, seed);
    let (m, n) = st.matrix.shape();
    let unc = Uncertainty::paper(m, n, st.resolution_pm);
    let p = SensingProblem::new(st.matrix.clone(), 250.0, true).unwrap().with_min_load_g(PAPER_MIN_LOAD_G).unwrap().with_uncertainty(unc).unwrap();
    let prior = ReadingSettings { max_loads: 4, resolution_pm: st.resolution_pm };
    let s = prepare(&p, &prior, &MethodRequest::named(Method::BranchAndBound), None).unwrap();
    println!("sigma {}", st.resolution_pm);
    let (mut amb_ok, mut ok, mut miss, mut amb_miss) = (0, 0, 0, 0);
    for (x0, y) in st.truth_g.iter().zip(&st.shifts_pm) {
        let r = s.reconstruct(y);
        let good = snr_db(x0, &r.loads_g) >= 12.0;
        let amb = r.flags.ambiguous;
        if good { ok += 1; if amb { amb_ok += 1; } } else { miss += 1; if amb { amb_miss += 1; } }
        if amb || !good {
            let t: Vec<(usize, f64)> = x0.iter().enumerate().filter(|(_, v)| **v > 0.0).map(|(j, v)| (j, (*v * 10.0).round() / 10.0)).collect();
            let a: Vec<(usize, f64)> = r.loads_g.iter().enumerate().filter(|(_, v)| **v > 0.0).map(|(j, v)| (j, (*v * 10.0).round() / 10.0)).collect();
            println!("good={good} amb={amb} margin={:?} chi2={:.1} dof={} truth={t:?} answer={a:?} flags={:?}", r.rival_margin_chi2, r.chi2, r.dof, r.flags.words());
        }
    }
    println!("ok {ok} amb_ok {amb_ok} miss {miss} amb_miss {amb_miss}");
}
