//! A scripted array run recorded as MCAP, to open in Foxglove or `ros2 bag`:
//!
//! ```text
//! cargo run -p fbgforge-publish --example mcap_demo -- run.mcap [SECONDS]
//! ```
//!
//! 1 kHz frames of the 4 × 2 array of `tactile-array-60x80`: 100 g pressed on each cell
//! in turn (0.5 s of every 2 s), after a 1 s rest in which the tare is waiting.

use fbgforge_publish::{ArrayReading, McapRecorder, RecorderSetup, SensorLayout, TareState};

const CELLS: [&str; 8] = ["A", "B", "C", "D", "E", "F", "G", "H"];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().ok_or("usage: mcap_demo FILE.mcap [SECONDS]")?;
    let seconds: u64 = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let setup = RecorderSetup {
        design_name: "tactile-array-60x80".into(),
        sensor: SensorLayout::Array {
            cell_labels: CELLS.map(String::from).to_vec(),
        },
        grating_labels: (1..=6).map(|k| format!("g{k}")).collect(),
    };
    let mut rec = McapRecorder::create(path, setup)?;
    let t0_ns: u64 = 1_700_000_000_000_000_000;
    for k in 0..seconds * 1000 {
        let t_s = k as f64 * 1e-3;
        let mut loads = [0.0; 8];
        let cell = (k / 2000) as usize % 8;
        let pressed = t_s >= 1.0 && k % 2000 < 500;
        if pressed {
            loads[cell] = 0.1 * 9.806_65;
        }
        // Cell centres 15 mm apart, 4 across, 2 up.
        let centre = [
            0.0075 + 0.015 * (cell % 4) as f64,
            0.0075 + 0.015 * (cell / 4) as f64,
            0.0,
        ];
        let peaks: Vec<Option<f64>> = (0..6)
            .map(|g| Some(1530.0 + 4.0 * g as f64 + if pressed { 0.02 } else { 0.0 }))
            .collect();
        rec.record_array(&ArrayReading {
            frame_time_ns: t0_ns + k * 1_000_000,
            cell_loads_n: &loads,
            contact_centroid_m: pressed.then_some(centre),
            peaks_nm: &peaks,
            flags: &[],
            tare: if t_s < 1.0 {
                &TareState::Waiting
            } else {
                &TareState::Resting
            },
        })?;
    }
    let summary = rec.finish()?;
    println!(
        "{}: {} frames, {} messages",
        summary.path.display(),
        summary.frames,
        summary.message_count()
    );
    Ok(())
}
