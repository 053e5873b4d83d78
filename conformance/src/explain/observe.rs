//! What a candidate shows a host: the model's observation with what the model does not hold
//! but a card has, its CPU type.

use pmacwd_model::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::event::Reply;
use pmacwd_specs::vocab::Observation;
use pmacwd_specs::Spec;

/// The status words with the CPU type bits of `cpu` (SRM p.289: X bit 21 is bit 1, Y bit 21
/// bit 0; 56303 = 0,0; 56309 = 0,1; 56311 = 1,0; 56321 = 1,1).
pub fn with_cpu(spec: &Spec, cpu: u8, (x, y): (u32, u32)) -> (u32, u32) {
    let mut w = [x, y];
    for (name, on) in [("cpu_type_bit1", cpu & 2 != 0), ("cpu_type_bit0", cpu & 1 != 0)] {
        if let (true, Some((word, bit))) = (on, spec.status.bit(name)) {
            w[match word {
                WordId::X => 0,
                WordId::Y => 1,
            }] |= 1 << bit;
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
