//! Lockstep checking speed: the compact core and the reference model on the same generated
//! traces (the lockstep test's distribution, fixed seed), observations compared after every
//! event. Throughput is in events applied (to both sides).
//!
//! Run: `cargo bench -p pmacwd-conformance --bench lockstep`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pmacwd_conformance::generate::{all_configs, run_choices, strategy, Choice, Generated};
use pmacwd_conformance::subject::CoreSubject;
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::Spec;
use proptest::strategy::{Strategy, ValueTree};
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn lockstep(c: &mut Criterion) {
    let spec = Spec::embedded().unwrap();
    let configs = all_configs(&spec).unwrap();
    let mut runner = TestRunner::new_with_rng(Config::default(), TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]));
    let strat = strategy(configs.len(), 1_000);
    let edges: Vec<Generated> = (0..200).map(|_| strat.new_tree(&mut runner).unwrap().current()).collect();
    // The same traces without the long idle gaps (servo runs of more than 4 cycles): the event
    // mix of a host polling a running card, where the model's cycle-by-cycle time costs little.
    let dense: Vec<Generated> = edges
        .iter()
        .map(|g| Generated {
            which: g.which,
            choices: g
                .choices
                .iter()
                .filter(|c| match c {
                    Choice::Event(Event::Servo { cycles }) => *cycles <= 4,
                    Choice::ServoToCounter(_) | Choice::ServoPastStrobeStop(_) => false,
                    _ => true,
                })
                .cloned()
                .collect(),
        })
        .collect();
    let mut g = c.benchmark_group("lockstep");
    g.sample_size(10);
    for (name, traces) in [("edge_weighted", &edges), ("dense", &dense)] {
        let run_all = || -> u64 {
            traces
                .iter()
                .map(|g| run_choices::<CoreSubject>(&configs[g.which], &g.choices, false, &mut |_, _, _| {}).unwrap())
                .sum()
        };
        let events = run_all();
        g.throughput(Throughput::Elements(events));
        g.bench_function(format!("{name}_{events}_events"), |b| b.iter(run_all));
    }
    g.finish();
}

criterion_group!(benches, lockstep);
criterion_main!(benches);
