//! The reference model on one servo event, for the ratio against the compact core
//! (`cargo bench -p pmacwd-core --bench core`, `servo_event_with_background`).
//!
//! Run: `cargo bench -p pmacwd-model --bench servo_event`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

fn model_benchmarks(c: &mut Criterion) {
    let mut g = c.benchmark_group("core");
    g.throughput(Throughput::Elements(1));
    // The reference model on the same servo event.
    let spec = pmacwd_specs::Spec::embedded().unwrap();
    let mcfg =
        pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.default_profile()).unwrap();
    g.bench_function("model_servo_event", |b| {
        let mut card = pmacwd_model::controller::Controller::power_on(&mcfg);
        b.iter(|| {
            card.servo_cycle(black_box(&mcfg));
            if card.background_possible() {
                card.background_cycle(&mcfg);
            }
        })
    });
    g.bench_function("model_step_servo_event", |b| {
        let model = pmacwd_model::checker::WatchdogModel::new(mcfg.clone());
        let mut state = pmacwd_model::checker::State {
            controller: pmacwd_model::controller::Controller::power_on(&mcfg),
            violations: 0,
        };
        b.iter(|| {
            let (_, next) = model.step(&state, &pmacwd_specs::vocab::event::Event::Servo { cycles: 1 });
            state = next;
            if state.controller.background_possible() {
                state.controller.background_cycle(&mcfg);
            }
        })
    });
    g.finish();
}

criterion_group!(benches, model_benchmarks);
criterion_main!(benches);
