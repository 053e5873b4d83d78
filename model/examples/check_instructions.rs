//! Runs the benchmark's exhaustive check of `timing` (default profile, one thread) `N` times
//! (`N` from the first argument, default 1; the configuration from the second, default
//! `timing`), for an instruction count under valgrind that does not depend on the machine's
//! load:
//!
//! ```sh
//! cargo build --release -p pmacwd-model --example check_instructions
//! for n in 1 2; do valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!   target/release/examples/check_instructions $n 2>&1 | grep 'Collected'; done
//! ```
//!
//! The difference of the two counts is one whole run as `model_check/timing_default_profile_1`
//! times it (model construction, the checker's thread, its maps, the search, the drop);
//! divided by the states it prints, the instructions per state.

use pmacwd_model::checker::WatchdogModel;
use pmacwd_specs::Spec;

fn main() {
    let n: u32 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1);
    let configuration = std::env::args().nth(2).unwrap_or_else(|| "timing".into());
    let spec = Spec::embedded().expect("embedded specs load");
    let cfg = pmacwd_specs::config::ModelConfig::from_spec(&spec, &configuration, &spec.profiles.default_profile())
        .expect("configuration resolves");
    for _ in 0..n {
        let states = WatchdogModel::new(cfg.clone()).check(1).states;
        println!("{states} states");
    }
}
