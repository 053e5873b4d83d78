//! The compact core on its own: one servo event, fast-forward, `???`. The reference model's
//! figures for the same events are `cargo bench -p pmacwd-model --bench servo_event`.
//!
//! Run: `cargo bench -p pmacwd-core --bench core`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
mod shared;

use pmacwd_core::{Command, Core, Event, FewIVariables, Reply};
use shared::{moving, realistic_config as config};

fn core_benchmarks(c: &mut Criterion) {
    let cfg = config();
    let mut g = c.benchmark_group("core");
    // One servo interrupt on a running card: batches of 1,000 from a fresh reload of I40 =
    // 4096, so the counter stays above zero and no batch trips (a tripped card does nothing).
    // Nothing reads the card within a batch, so after its first cycles (taken in full until
    // the counter has fallen eight) the cycles are deferred in a quiet stretch: this measures
    // the servo event as a host that only reads now and then sees it (docs/core.md).
    // `servo_event_with_background` below is the other end: no stretch ever begins.
    g.throughput(Throughput::Elements(1_000));
    g.bench_function("servo_event_x1000", |b| {
        let start = Core::power_on(&cfg);
        b.iter(|| {
            let mut core = start;
            for _ in 0..1_000 {
                core.servo_cycle(black_box(&cfg));
            }
            core
        })
    });
    // The cost per moving motor: batches of 200 servo interrupts (within the 255-cycle stops)
    // with 0, 1 and 8 motors decelerating, the other motors jogging.
    g.throughput(Throughput::Elements(200));
    for stopping in [0u8, 1, 8] {
        g.bench_function(format!("servo_event_x200_{stopping}_decelerating"), |b| {
            let (cfg, start) = moving(stopping);
            b.iter(|| {
                let mut core = start;
                for _ in 0..200 {
                    core.servo_cycle(black_box(&cfg));
                }
                core
            })
        });
    }
    g.throughput(Throughput::Elements(1));
    // One servo interrupt, with a background cycle whenever possible so the card never trips.
    g.bench_function("servo_event_with_background", |b| {
        let mut core = Core::power_on(&cfg);
        b.iter(|| {
            core.servo_cycle(black_box(&cfg));
            if core.background_possible() {
                core.background_cycle(&cfg);
            }
        })
    });
    for n in [1u32, 1_000, 1_000_000_000] {
        g.bench_function(format!("advance_{n}"), |b| {
            let start = Core::power_on(&cfg);
            b.iter(|| {
                let mut core = start;
                core.advance(&cfg, black_box(n));
                core
            })
        });
    }
    g.bench_function("status_reply", |b| {
        let mut core = Core::power_on(&cfg);
        let mut store = FewIVariables::<4>::default();
        b.iter(|| match core.apply(&cfg, Event::Command(black_box(Command::GlobalStatus)), &mut store) {
            Reply::Status { x, y } => Reply::status_text(x, y),
            _ => [0; 12],
        })
    });
    g.finish();
}

criterion_group!(benches, core_benchmarks);
criterion_main!(benches);
