//! Replay throughput: a day-long host log of a healthy card (X:$0, `???`, Y:$25 and X:$25
//! polled every half second at 2.25 kHz: 172,800 polls, 864,000 events) judged by the search
//! under every combination of readings, explanation included. The log is synthetic, written
//! by `samples::healthy_day` below from a small simulation of a card whose background cycle
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
    writeln!(f, r#"{{"format":"pmacwd-trace","version":1,"description":"SYNTHETIC: a day of a healthy card with a DSP56321, polled every 0.5 s","configuration":"host-log","profiles":"all"}}"#).unwrap();
    writeln!(f, r#"{{"command":"$$$"}}"#).unwrap();
    let (r, mut counter, mut lowest, mut area, mut since) = (4096i32, 4096i32, 4096i32, 0u32, 0u32);
    let mut seed = 1u64;
    for _ in 0..POLLS {
        for _ in 0..1125 {
            counter -= 1;
            lowest = lowest.min(counter);
            since += 1;
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            if since >= 9 + ((seed >> 33) % 5) as u32 {
                counter = r;
                since = 0;
                area ^= 1;
            }
        }
        writeln!(f, r#"{{"elapsed":1125}}"#).unwrap();
        writeln!(f, r#"{{"command":"RHX:$0"}}"#).unwrap();
        let x = if area == 0 { 0x20_1000 } else { 0x20_0000 };
        writeln!(f, r#"{{"command":"???","expect":{{"reply":"{x:06X}200000"}}}}"#).unwrap();
        writeln!(f, r#"{{"command":"RHY:$25","expect":{{"reply":"{:06X}"}}}}"#, counter & 0xFF_FFFF).unwrap();
        writeln!(f, r#"{{"command":"RHX:$25","expect":{{"reply":"{:06X}"}}}}"#, lowest & 0xFF_FFFF).unwrap();
    }
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
