use fbgforge::array::methods::{Method, ReadingSettings};
use fbgforge::array::reconstruct::{prepare, MethodRequest};
use fbgforge_studies::reconstruct_flags::gen::{arrays, stream, Fault};
use fbgforge::array::problem::{SensingProblem, Uncertainty, PAPER_MIN_LOAD_G};
use fbgforge::array::protocol::snr_db;
use rayon::prelude::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let ai: usize = args[1].parse().unwrap();
    let streams: u64 = args[2].parse().unwrap();
    let method = Method::from_name(args.get(3).map(|s| s.as_str()).unwrap_or("bnb")).unwrap();
    let arr = &arrays(false)[ai];
    let alphas = [1e-4, 1e-3, 0.01, 0.05, 0.1, 0.2, 0.4];
    let res: Vec<(Vec<(bool, Vec<bool>)>, f64)> = (0..streams).into_par_iter().map(|s| {
        let st = stream(arr, Fault::Clean, 200, 900 + s);
        let (m, n) = st.matrix.shape();
        let unc = Uncertainty::paper(m, n, st.resolution_pm);
        let p = SensingProblem::new(st.matrix.clone(), 250.0, true).unwrap().with_min_load_g(PAPER_MIN_LOAD_G).unwrap().with_uncertainty(unc).unwrap().with_significance(1e-4).unwrap();
        let prior = ReadingSettings { max_loads: 4, resolution_pm: st.resolution_pm };
        let setup = prepare(&p, &prior, &MethodRequest::named(method), None).unwrap();
        let t = std::time::Instant::now();
        let v = st.truth_g.iter().zip(&st.shifts_pm).map(|(x0, y)| {
            let r = setup.reconstruct(y);
            let good = snr_db(x0, &r.loads_g) >= 12.0;
            if std::env::var("I35_WORDS").is_ok() { eprintln!("W {} {:?} k={}", good, r.flags_at(std::env::var("I35_A").ok().and_then(|v| v.parse().ok()).unwrap_or(0.01)).words(), x0.iter().filter(|v| **v > 0.0).count()); }
            (good, alphas.iter().map(|&a| !r.flags_at(a).trusted()).collect())
        }).collect();
        (v, t.elapsed().as_secs_f64() / 200.0 * 1e6)
    }).collect();
    let all: Vec<&(bool, Vec<bool>)> = res.iter().flat_map(|r| &r.0).collect();
    let ok = all.iter().filter(|f| f.0).count();
    let miss = all.len() - ok;
    let us: f64 = res.iter().map(|r| r.1).sum::<f64>() / res.len() as f64;
    println!("{} {}: frames {} RR {:.1} missed {} ({:.0} us/frame incl test)", arr.name, method.name(), all.len(), 100.0 * ok as f64 / all.len() as f64, miss, us);
    for (k, a) in alphas.iter().enumerate() {
        let fo = all.iter().filter(|f| f.0 && f.1[k]).count();
        let fm = all.iter().filter(|f| !f.0 && f.1[k]).count();
        println!("  alpha {a}: false {:.1}%  recall {:.1}%", 100.0 * fo as f64 / ok as f64, 100.0 * fm as f64 / miss.max(1) as f64);
    }
}
