//! The servo event's cost as the best of 50 runs of 10^7 cycles each: on a machine shared with
//! other work, criterion's median measures the load as much as the code, while the fastest run
//! is the one least disturbed. Idle motors, then eight jogging motors with 0, 1, 2, 4 and 8 of
//! them decelerating (the cost per moving motor).
//!
//! Run: `cargo run --release -p pmacwd-core --example servo_best_of`.

#[path = "../benches/shared/mod.rs"]
mod shared;

use pmacwd_core::{Config, Core};
use shared::{moving, realistic_config};
use std::hint::black_box;

/// Nanoseconds per servo cycle, the best of 50 runs of 10^7 cycles in batches of `batch`
/// from `start` (batches of 200 stay within the 255-cycle stops).
fn best(cfg: &Config, start: Core, batch: u32) -> f64 {
    let mut best = f64::MAX;
    for _ in 0..50 {
        let t = std::time::Instant::now();
        for _ in 0..10_000_000 / batch {
            let mut core = black_box(start);
            for _ in 0..batch {
                core.servo_cycle(black_box(cfg));
            }
            black_box(core);
        }
        best = best.min(t.elapsed().as_secs_f64() * 100.0);
    }
    best
}

fn main() {
    let cfg = realistic_config();
    println!("motors idle (killed), batches of 1,000: {:.2} ns", best(&cfg, Core::power_on(&cfg), 1_000));
    for stopping in [0u8, 1, 2, 4, 8] {
        let (cfg, start) = moving(stopping);
        println!("8 motors jogging, {stopping} decelerating, batches of 200: {:.2} ns", best(&cfg, start, 200));
    }
}
