//! Criterion time per frame of the live mode's work once a frame's bytes have arrived:
//! decode the Hyperion message, find each grating's peak, take the shift and turn it
//! into cell loads (the paper's array, its default method) or forces (the 34 mm
//! module). Every frame carries 16 peaks (the design's gratings plus other sensors'
//! peaks on a second channel), as an interrogator with 16 gratings sends them. The
//! sustained end-to-end rate (`synth-stream` → `live` over loopback) is measured in
//! docs/live.md. Run with `cargo bench --bench live`.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use fbgforge::live::hyperion::StreamDecoder;
use fbgforge::live::interpret::{InterpretOptions, Interpreter};
use fbgforge::live::source::Frame;
use fbgforge::synth::stream::{Generator, SynthNoise, SynthRequest};
use std::path::Path;
use std::time::Instant;

fn frames(design: &str, core: Option<&str>, extra: usize, n: u64) -> (Interpreter, Vec<Vec<u8>>) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("designs")
        .join(design);
    let d = fbgforge::design::load(&p).expect("shipped design loads");
    let mut req = SynthRequest::new(p);
    req.extra_peaks = extra;
    req.noise = SynthNoise::Paper;
    req.core = core.map(str::to_string);
    let script = fbgforge::synth::stream::default_script(&d).unwrap();
    let mut g = Generator::with_script(&d, script, &req).unwrap();
    // Skip the rest period of the demo script: loaded frames.
    let bytes = (600..600 + n).map(|k| g.encoded(k, 0.0).0).collect();
    let opts = InterpretOptions {
        tare_frames: 0,
        core: core.map(str::to_string),
        ..InterpretOptions::default()
    };
    (Interpreter::new(&d, &opts).unwrap(), bytes)
}

fn read(interp: &mut Interpreter, dec: &mut StreamDecoder, bytes: &[u8]) -> usize {
    dec.push(bytes);
    let f = dec.next_frame().unwrap().unwrap();
    let frame = Frame {
        serial: Some(f.serial_number),
        time_s: Some(f.timestamp_s),
        wall_clock: true,
        peaks_nm: f.peaks_nm,
        received: Instant::now(),
        origin: String::new(),
    };
    let p = interp.prepare(&frame).result.unwrap();
    interp.solve(&[p]).len()
}

fn per_frame(c: &mut Criterion) {
    let mut g = c.benchmark_group("live per frame (16 peaks)");
    g.throughput(Throughput::Elements(1));
    for (name, design, core, extra) in [
        ("array 6x8 wsupport", "tactile-array-60x80.toml", None, 10),
        ("module psc2 forces", "clip-on-34mm.toml", Some("psc2"), 13),
    ] {
        let (mut interp, bytes) = frames(design, core, extra, 1000);
        let mut dec = StreamDecoder::new();
        let mut k = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) % bytes.len();
                read(&mut interp, &mut dec, &bytes[k])
            })
        });
    }
    g.finish();

    // A backlog of 256 frames: the batch is reconstructed in parallel (both cores).
    let mut g = c.benchmark_group("live batch of 256 frames");
    g.throughput(Throughput::Elements(256));
    let (mut interp, bytes) = frames("tactile-array-60x80.toml", None, 10, 256);
    g.bench_function("array 6x8 wsupport", |b| {
        b.iter_batched(
            || bytes.concat(),
            |all| {
                let mut dec = StreamDecoder::new();
                dec.push(&all);
                let mut prepared = Vec::with_capacity(256);
                while let Some(Ok(f)) = dec.next_frame() {
                    let frame = Frame {
                        serial: Some(f.serial_number),
                        time_s: None,
                        wall_clock: false,
                        peaks_nm: f.peaks_nm,
                        received: Instant::now(),
                        origin: String::new(),
                    };
                    prepared.push(interp.prepare(&frame).result.unwrap());
                }
                interp.solve(&prepared).len()
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, per_frame);
criterion_main!(benches);
