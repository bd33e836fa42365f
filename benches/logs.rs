//! Criterion throughput of the wavelength log parsers on a synthetic 8-grating log at
//! 1 kHz (ENLIGHT peaks: about 20 MB a minute), one case per format: bytes per second.
//! Run with `cargo bench --bench logs`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use fbgforge::logs::{self, LogFormat, ReadOptions};
use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig};
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
    let mut g = c.benchmark_group("logs");
    g.sample_size(10);
    for format in LogFormat::ALL {
        let path = dir
            .path()
            .join(format!("{}.{}", format.name(), synth::extension(format)));
        synth::write_log(&path, format, &log, &cfg, &LogStyle::default()).expect("log written");
        let bytes = std::fs::read(&path).expect("log read");
        g.throughput(Throughput::Bytes(bytes.len() as u64));
        let name = match format {
            LogFormat::EnlightPeaks => "parse ENLIGHT peaks (memory)".to_string(),
            f => format!("parse {} (memory)", f.name()),
        };
        g.bench_function(name, |b| {
            b.iter(|| logs::parse_wavelength_bytes(&bytes, &path, &ReadOptions::default()).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, enlight_parse);
criterion_main!(benches);
