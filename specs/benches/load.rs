//! The spec load every command pays at start-up (issue 32), as criterion times:
//!
//! - `spec_load/all_files`: the nine spec files parsed, validated and the requirements'
//!   `spec` references resolved, from texts in memory (what `Spec::embedded` does once per
//!   process);
//! - `spec_load/requirements_yaml`: `requirements.yaml` alone parsed into its source map, the
//!   largest file (80 KB), for the share of the whole that is parsing.
//!
//! Run: `cargo bench -p pmacwd-specs --bench load`. Figures: docs/performance.md, "Start-up".

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use pmacwd_specs::yaml::SourceMap;
use pmacwd_specs::Spec;
use std::path::Path;

fn spec_load(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let texts: Vec<(&str, String)> = Spec::file_names()
        .map(|n| (n, std::fs::read_to_string(dir.join(n)).expect("a spec file of this tree")))
        .collect();
    let named: Vec<(&str, &str)> = texts.iter().map(|(n, t)| (*n, t.as_str())).collect();
    let bytes: usize = named.iter().map(|(_, t)| t.len()).sum();
    let mut g = c.benchmark_group("spec_load");
    g.throughput(Throughput::Bytes(bytes as u64));
    g.bench_function("all_files", |b| {
        b.iter(|| Spec::from_named_texts(Path::new("specs"), black_box(&named)).expect("the shipped specs load"))
    });
    let requirements = named.iter().find(|(n, _)| *n == "requirements.yaml").expect("requirements.yaml").1;
    g.throughput(Throughput::Bytes(requirements.len() as u64));
    g.bench_function("requirements_yaml", |b| {
        b.iter(|| SourceMap::build(Path::new("requirements.yaml"), black_box(requirements)).expect("it parses"))
    });
    g.finish();
}

criterion_group!(benches, spec_load);
criterion_main!(benches);
