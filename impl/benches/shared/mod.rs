//! What the core's benchmark and the best-of example both run: the realistic configuration, and
//! a card with its motors moving (`tests/common/mod.rs`, which the tests share too).

#[path = "../../tests/common/mod.rs"]
mod common;

pub use common::realistic_config;
use pmacwd_core::{Config, Core};

/// Eight jogging motors, `stopping` of them decelerating for 255 servo cycles (longer than a
/// batch of 200, so every cycle of the batch has them under way).
pub fn moving(stopping: u8) -> (Config, Core) {
    common::moving(255, stopping)
}
