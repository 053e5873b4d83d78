//! The compact core on its own: one servo event, fast-forward, `???`. The reference model's
//! figures for the same events are `cargo bench -p pmacwd-model --bench servo_event`.
//!
//! Run: `cargo bench -p pmacwd-core --bench core`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
#[path = "../tests/common/mod.rs"]
mod common;

use common::realistic_config as config;
use pmacwd_core::motion::MotorCommand;
use pmacwd_core::{Command, Config, Core, Event, FewIVariables, MotionCommand, MotionConfig, Reply};

/// A running card whose eight motors are closed-loop and jogging, `stopping` of them
/// decelerating from a J/ for 255 servo cycles (longer than a batch, so every cycle of the
/// batch has them under way). Jogging motors cost a servo cycle nothing (the core represents
/// no trajectory); a stop under way is what a cycle has to count down.
fn moving(stopping: u8) -> (Config, Core) {
    let cfg = Config { motion: MotionConfig::all_in_cs1(8, 255), ..config() };
    let mut core = Core::power_on(&cfg);
    let mut store = FewIVariables::<4>::default();
    let mut send = |core: &mut Core, n: u8, c: MotorCommand| {
        core.apply(&cfg, Event::Command(Command::Motion(MotionCommand::Motor(n, c))), &mut store)
    };
    for n in 1..=8 {
        send(&mut core, n, MotorCommand::JogStop);
        send(&mut core, n, MotorCommand::Jog);
    }
    for n in 1..=stopping {
        send(&mut core, n, MotorCommand::JogStop);
    }
    (cfg, core)
}

fn core_benchmarks(c: &mut Criterion) {
    let cfg = config();
    let mut g = c.benchmark_group("core");
    // One servo interrupt on a running card: batches of 1,000 from a fresh reload of I40 =
    // 4096, so the counter stays above zero and no batch trips (a tripped card does nothing).
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
