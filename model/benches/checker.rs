//! States per second of the exhaustive check, at the `timing` configuration of the embedded
//! specs under the default profile. criterion reports it as throughput (elements = states).
//!
//! Run: `cargo bench -p pmacwd-model --bench checker`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pmacwd_model::checker::WatchdogModel;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::Spec;

fn checker_states_per_second(c: &mut Criterion) {
    let spec = Spec::embedded().expect("embedded specs load");
    let profile = spec.profiles.default_profile();
    let cfg = ModelConfig::from_spec(&spec, "timing", &profile).expect("small configuration resolves");
    let states = WatchdogModel::new(cfg.clone()).check(1).states as u64;
    let mut group = c.benchmark_group("model_check");
    group.sample_size(10);
    group.throughput(Throughput::Elements(states));
    for threads in [1usize, 2] {
        group.bench_function(format!("timing_default_profile_{threads}_threads"), |b| {
            b.iter(|| WatchdogModel::new(cfg.clone()).check(threads).states)
        });
    }
    group.finish();
}

criterion_group!(benches, checker_states_per_second);
criterion_main!(benches);
