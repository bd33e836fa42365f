//! Criterion throughput of the ENLIGHT peaks parser on a synthetic 8-grating log at
//! 1 kHz (about 20 MB a minute): bytes per second. Run with `cargo bench --bench logs`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fbgforge::logs::{self, LogFormat, ReadOptions};
use fbgforge::verify::synth::{self, LogStyle, SynthConfig};
use std::path::Path;

fn enlight_parse(c: &mut Criterion) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/clip-on-34mm.toml");
    let design = fbgforge::design::load(&p).expect("shipped design loads");
    let cfg = SynthConfig {
        sample_rate_hz: 1000.0,
        force_rate_hz: 1000.0,
        pulses: synth::pulse_train(&[10.0, 20.0, 30.0], 4.0, 6.0, 5.0),
        duration_s: 40.0,
        ..Default::default()
    };
    let (log, _, _) = synth::generate(&design, &cfg).expect("synthetic log");
    let dir = tempfile::tempdir().expect("temporary folder");
    let path = dir.path().join("peaks.txt");
    synth::write_log(
        &path,
        LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )
    .expect("log written");
    let bytes = std::fs::read(&path).expect("log read");
    let mut g = c.benchmark_group("logs");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(bytes.len() as u64));
    g.bench_function("parse ENLIGHT peaks (memory)", |b| {
        b.iter(|| logs::parse_wavelength_bytes(&bytes, &path, &ReadOptions::default()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, enlight_parse);
criterion_main!(benches);
