//! Replay throughput: events per second of `pmacwd replay` on a 100,000-event JSON Lines
//! capture of a healthy card polled by a host, every profile in lockstep (parsing included).
//!
//! Run: `cargo bench -p pmacwd-conformance --bench replay`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pmacwd_conformance::replay::replay;
use pmacwd_specs::Spec;
use std::io::Write;

const EVENTS: u64 = 100_000;

fn replay_events_per_second(c: &mut Criterion) {
    let path = std::env::temp_dir().join(format!("pmacwd-bench-replay-{}.jsonl", std::process::id()));
    {
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        writeln!(f, r#"{{"format":"pmacwd-trace","version":1,"description":"SYNTHETIC benchmark","configuration":"i40-zero","profiles":"all"}}"#).unwrap();
        for _ in 0..EVENTS / 4 {
            writeln!(f, r#"{{"servo":4}}"#).unwrap();
            writeln!(f, r#"{{"background":1}}"#).unwrap();
            writeln!(f, r#"{{"command":"???","expect":{{"tripped":false}}}}"#).unwrap();
            writeln!(f, r#"{{"command":"RHY:$25"}}"#).unwrap();
        }
    }
    let spec = Spec::embedded().unwrap();
    let mut group = c.benchmark_group("replay");
    group.sample_size(10);
    group.throughput(Throughput::Elements(EVENTS));
    group.bench_function("jsonl_100k_events_all_profiles", |b| b.iter(|| replay(&spec, &path).unwrap().events));
    group.finish();
    let _ = std::fs::remove_file(&path);
}

criterion_group!(benches, replay_events_per_second);
criterion_main!(benches);
