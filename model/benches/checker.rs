//! The exhaustive check's speed, as criterion throughputs:
//!
//! - `model_check/timing_default_profile_{1,2}_threads`: states per second at the `timing`
//!   configuration (one servo cycle at a time) under the default profile;
//! - `model_check/i40_zero_default_profile_1_thread`: states per second at `i40-zero`, where
//!   most of the time goes into the leaps;
//! - `leap/i40_zero_starved`: servo cycles per second inside one leap, the longest of
//!   `i40-zero` (a starved background, the counter running down from 4096 to the trip).
//!
//! Run: `cargo bench -p pmacwd-model --bench checker`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use pmacwd_model::checker::{State, WatchdogModel};
use pmacwd_model::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::Spec;

fn config(name: &str) -> ModelConfig {
    let spec = Spec::embedded().expect("embedded specs load");
    ModelConfig::from_spec(&spec, name, &spec.profiles.default_profile()).expect("configuration resolves")
}

fn checker_states_per_second(c: &mut Criterion) {
    let mut group = c.benchmark_group("model_check");
    group.sample_size(10);
    let timing = config("timing");
    let states = WatchdogModel::new(timing.clone()).check(1).states as u64;
    group.throughput(Throughput::Elements(states));
    for threads in [1usize, 2] {
        group.bench_function(format!("timing_default_profile_{threads}_threads"), |b| {
            b.iter(|| WatchdogModel::new(timing.clone()).check(threads).states)
        });
    }
    let i40_zero = config("i40-zero");
    let states = WatchdogModel::new(i40_zero.clone()).check(1).states as u64;
    group.throughput(Throughput::Elements(states));
    group.bench_function("i40_zero_default_profile_1_thread", |b| {
        b.iter(|| WatchdogModel::new(i40_zero.clone()).check(1).states)
    });
    group.finish();
}

/// One leap to the next change from power-up under the load that starves the background: the
/// counter runs down from the reset value with nothing for the environment to react to.
fn leap_cycles_per_second(c: &mut Criterion) {
    let cfg = config("i40-zero");
    let model = WatchdogModel::new(cfg.clone());
    let power_on = State { controller: Controller::power_on(&cfg), violations: 0 };
    // The load whose first leap is longest (the starved one of check.yaml).
    let (cycles, start) = cfg
        .loads
        .iter()
        .map(|load| {
            let (_, s) = model.step(&power_on, &Event::Load(*load));
            (model.advance_to_change(&s, false).0, s)
        })
        .max_by_key(|(cycles, _)| *cycles)
        .expect("i40-zero has loads");
    let mut group = c.benchmark_group("leap");
    group.throughput(Throughput::Elements(u64::from(cycles)));
    group.bench_with_input(BenchmarkId::new("i40_zero_starved", cycles), &start, |b, s| {
        b.iter(|| model.advance_to_change(s, false).0)
    });
    group.finish();
}

criterion_group!(benches, checker_states_per_second, leap_cycles_per_second);
criterion_main!(benches);
