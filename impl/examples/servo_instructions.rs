//! Runs `N` idle servo cycles once (`N` from the first argument, default 10^6), for an
//! instruction count under valgrind that does not depend on the machine's load:
//!
//! ```sh
//! cargo build --release -p pmacwd-core --example servo_instructions
//! for n in 0 1000000; do valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!   target/release/examples/servo_instructions $n 2>&1 | grep 'Collected'; done
//! ```
//!
//! The difference of the two counts over 10^6 is the instructions per idle servo cycle.

#[path = "../benches/shared/mod.rs"]
#[allow(dead_code)]
mod shared;

use pmacwd_core::Core;
use std::hint::black_box;

fn main() {
    let n: u32 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1_000_000);
    let cfg = shared::realistic_config();
    let start = Core::power_on(&cfg);
    // Batches of 1,000 from a fresh reload, as the benchmark does: no batch trips.
    let mut done = 0;
    while done < n {
        let mut core = black_box(start);
        for _ in 0..1_000.min(n - done) {
            core.servo_cycle(black_box(&cfg));
        }
        black_box(core);
        done += 1_000.min(n - done);
    }
}
