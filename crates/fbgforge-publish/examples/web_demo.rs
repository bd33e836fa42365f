//! The browser view with a scripted sensor, to look at it by hand:
//!
//! ```text
//! cargo run -p fbgforge-publish --example web_demo -- [array|module] [ADDR] [SECONDS]
//! ```
//!
//! serves on ADDR (default 127.0.0.1:8642) for SECONDS (default 60) and pushes 20
//! frames/s: the array presses 100 g on each cell in turn (0.5 s of every 2 s); the
//! module's two cores carry a slow sine and a step.

use std::time::{Duration, Instant};

use fbgforge_publish::web::{serve, ArrayView, FrameView, LoadUnit, ModuleView, ReadingView};
use fbgforge_publish::TareState;

fn array_frame(t_s: f64) -> ReadingView {
    let cell = ((t_s / 2.0) as usize) % 8;
    let pressed = t_s % 2.0 < 0.5;
    let mut loads = vec![0.0; 8];
    if pressed {
        loads[cell] = 100.0;
    }
    ReadingView::Array(ArrayView {
        nx: 4,
        ny: 2,
        cell_labels: ["A", "B", "C", "D", "E", "F", "G", "H"]
            .map(String::from)
            .to_vec(),
        cell_loads: loads,
        load_unit: LoadUnit::Grams,
        full_scale: Some(250.0),
    })
}

fn module_frame(t_s: f64) -> ReadingView {
    let sine = 2.5 + 2.5 * (t_s * 0.8).sin();
    let step = if t_s % 6.0 < 3.0 { 0.0 } else { 4.0 };
    ReadingView::Module(ModuleView {
        core_labels: vec!["psc1".into(), "psc2".into()],
        core_forces_n: vec![Some(sine), Some(step)],
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let kind = args.first().map_or("array", String::as_str).to_owned();
    let addr = args.get(1).map_or("127.0.0.1:8642", String::as_str);
    let seconds: f64 = args.get(2).map_or(Ok(60.0), |s| s.parse())?;
    let view = serve(addr)?;
    println!("{} ({kind}) for {seconds} s", view.url());
    let t0 = Instant::now();
    while t0.elapsed().as_secs_f64() < seconds {
        let t_s = t0.elapsed().as_secs_f64();
        let reading = if kind == "module" {
            module_frame(t_s)
        } else {
            array_frame(t_s)
        };
        view.push(&FrameView {
            design_name: if kind == "module" {
                "clip-on-10mm"
            } else {
                "tactile-array-60x80"
            }
            .into(),
            frame_time_ns: (t_s * 1e9) as u64,
            reading,
            flags: vec![],
            tare: if t_s < 1.0 {
                TareState::Waiting
            } else {
                TareState::Resting
            },
        })?;
        std::thread::sleep(Duration::from_millis(50));
    }
    println!("{:?}", view.stats());
    Ok(())
}
