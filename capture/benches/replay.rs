//! Replay throughput: a day-long host log of a healthy card (X:$0, `???`, Y:$25 and X:$25
//! polled every half second at 2.25 kHz: 172,800 polls, 864,000 events) judged by the search
//! under every combination of readings, explanation included. The log is synthetic, written
//! by `pmacwd_capture::samples::HealthyPolls` from a small simulation of a card whose background cycle
//! completes every 9 to 13 servo cycles.
//!
//! Run: `cargo bench -p pmacwd-capture --bench replay`. For peak memory, write the log with
//! `PMACWD_BENCH_KEEP=1` and time `pmacwd replay` on it with `/usr/bin/time -v` (docs/replay.md).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pmacwd_capture::explain::report::explain;
use pmacwd_specs::Spec;
use std::io::Write;

const POLLS: u64 = 172_800;

/// Writes the day-long capture to `path`.
fn healthy_day(path: &std::path::Path) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    pmacwd_capture::samples::HealthyPolls {
        polls: POLLS,
        gap_cycles: 1125,
        seed: 1,
        profiles: r#""all""#,
        description: "SYNTHETIC: a day of a healthy card with a DSP56321, polled every 0.5 s",
    }
    .write(&mut f)
    .unwrap();
    f.flush().unwrap();
}

fn replay_a_day(c: &mut Criterion) {
    let path = std::env::temp_dir().join(format!("pmacwd-bench-day-{}.jsonl", std::process::id()));
    healthy_day(&path);
    let spec = Spec::embedded().unwrap();
    let mut group = c.benchmark_group("replay");
    group.sample_size(10);
    group.throughput(Throughput::Elements(POLLS * 5 + 1));
    group.bench_function("host_log_day_2hz_all_readings", |b| {
        b.iter(|| {
            let r = explain(&spec, &path, None).unwrap();
            assert!(r.explained());
            r.events
        })
    });
    group.finish();
    if std::env::var_os("PMACWD_BENCH_KEEP").is_some() {
        eprintln!("capture kept at {}", path.display());
    } else {
        let _ = std::fs::remove_file(&path);
    }
}

criterion_group!(benches, replay_a_day);
criterion_main!(benches);
