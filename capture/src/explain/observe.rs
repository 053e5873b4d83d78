//! What a candidate shows a host: the model's observation with what a capture cannot assume
//! of the card, its CPU type, as the candidate's own.

use pmacwd_model::controller::Controller;
use pmacwd_specs::config::{ModelConfig, StatusLayout};
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::event::Reply;
use pmacwd_specs::vocab::Observation;

/// The status words with the CPU type bits of `cpu` (SRM p.289: X bit 21 is bit 1, Y bit 21
/// bit 0; 56303 = 0,0; 56309 = 0,1; 56311 = 1,0; 56321 = 1,1), whatever the words held there:
/// the model reports its configuration's processor, and the search replaces it with each CPU
/// it keeps open.
///
/// The bits' places come from `layout` (found once by name in `status.yaml`): looking them up
/// by name for every candidate at every step was 14% of a healthy poll's replay.
pub fn with_cpu(layout: &StatusLayout, cpu: u8, (x, y): (u32, u32)) -> (u32, u32) {
    let mut w = [x, y];
    for ((word, bit), on) in [(layout.cpu_type_bit1, cpu & 2 != 0), (layout.cpu_type_bit0, cpu & 1 != 0)] {
        let slot = &mut w[match word {
            WordId::X => 0,
            WordId::Y => 1,
        }];
        *slot = (*slot & !(1 << bit)) | (u32::from(on) << bit);
    }
    (w[0], w[1])
}

/// What `card` with CPU type `cpu` shows after `reply`.
pub fn observation(cfg: &ModelConfig, card: &Controller, cpu: u8, reply: Reply) -> Observation {
    let mut obs = pmacwd_model::observe::of(card, cfg, reply);
    let (x, y) = with_cpu(&cfg.layout, cpu, (obs.status_x, obs.status_y));
    obs.status_x = x;
    obs.status_y = y;
    if let Reply::Status { .. } = reply {
        obs.reply = Reply::Status { x, y };
    }
    obs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_candidate_s_cpu_type_replaces_the_bits_the_configuration_s_processor_set() {
        // The model reports its configuration's processor (check.yaml `processor:`); a
        // candidate of another CPU type must show its own bits, cleared ones included.
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let layout = StatusLayout::of(&spec).unwrap();
        let both = 1 << 21;
        assert_eq!(with_cpu(&layout, 0, (both | 1, both | 2)), (1, 2), "DSP56303: both cleared, the rest kept");
        assert_eq!(with_cpu(&layout, 1, (both, both)), (0, both), "DSP56309: Y21 only");
        assert_eq!(with_cpu(&layout, 2, (0, 0)), (both, 0), "DSP56311: X21 only");
        assert_eq!(with_cpu(&layout, 3, (0, 0)), (both, both), "DSP56321: both");
    }
}
