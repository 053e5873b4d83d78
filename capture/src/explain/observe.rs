//! What a candidate shows a host: the model's observation with what a capture cannot assume
//! of the card, its CPU type, as the candidate's own.

use pmacwd_model::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::event::Reply;
use pmacwd_specs::vocab::Observation;
use pmacwd_specs::Spec;

/// The status words with the CPU type bits of `cpu` (SRM p.289: X bit 21 is bit 1, Y bit 21
/// bit 0; 56303 = 0,0; 56309 = 0,1; 56311 = 1,0; 56321 = 1,1), whatever the words held there:
/// the model reports its configuration's processor, and the search replaces it with each CPU
/// it keeps open.
pub fn with_cpu(spec: &Spec, cpu: u8, (x, y): (u32, u32)) -> (u32, u32) {
    let mut w = [x, y];
    for (name, on) in [("cpu_type_bit1", cpu & 2 != 0), ("cpu_type_bit0", cpu & 1 != 0)] {
        if let Some((word, bit)) = spec.status.bit(name) {
            let slot = &mut w[match word {
                WordId::X => 0,
                WordId::Y => 1,
            }];
            *slot = (*slot & !(1 << bit)) | (u32::from(on) << bit);
        }
    }
    (w[0], w[1])
}

/// What `card` with CPU type `cpu` shows after `reply`.
pub fn observation(spec: &Spec, cfg: &ModelConfig, card: &Controller, cpu: u8, reply: Reply) -> Observation {
    let mut obs = pmacwd_model::observe::of(card, cfg, reply);
    let (x, y) = with_cpu(spec, cpu, (obs.status_x, obs.status_y));
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
        let spec = Spec::embedded().unwrap();
        let both = 1 << 21;
        assert_eq!(with_cpu(&spec, 0, (both | 1, both | 2)), (1, 2), "DSP56303: both cleared, the rest kept");
        assert_eq!(with_cpu(&spec, 1, (both, both)), (0, both), "DSP56309: Y21 only");
        assert_eq!(with_cpu(&spec, 2, (0, 0)), (both, 0), "DSP56311: X21 only");
        assert_eq!(with_cpu(&spec, 3, (0, 0)), (both, both), "DSP56321: both");
    }
}
