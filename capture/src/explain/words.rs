//! What no card shows in one status word under a lane's readings, whatever its state.
//!
//! Bits 13 and 12 of X:$000006 come from the checksum engine alone: bit 13 is any checksum
//! error found, bit 12 the area of the engine or of the error (SRM p.289, UM p.217), or, under
//! the M83 reading of bit 12, the firmware checksum error bit. So a `???` reply whose pair of
//! them no state of the engine gives (under M83: bit 12 without bit 13) is one no card shows,
//! whatever the timing of the log or the card's tolerances. A lane that died at such a reply
//! is not searched again under the other cards of the bands (`search::search`): none can get
//! past it. The pairs are found by building each engine state and asking the model's own
//! status word, so a rule changed in the model changes them here.
//!
//! Likewise bit 22 without bit 9 under the sticky reading of bit 9 ([`bit22_implies_bit9`],
//! checked on the model by this module's test).

use crate::replay::{ImportAs, Source};
use pmacwd_model::controller::Controller;
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::RtiWarningLatch;
use pmacwd_specs::status::WordId;
use pmacwd_specs::vocab::reply_text::{self, StatusReply};
use pmacwd_specs::{Spec, SpecError};
use std::path::Path;

/// Which pairs (bit 13, bit 12) some state of the checksum engine gives under `cfg`'s readings:
/// index `bit13 << 1 | bit12`.
pub fn engine_pairs(cfg: &ModelConfig) -> [bool; 4] {
    let mut seen = [false; 4];
    let mut card = Controller::power_on(cfg);
    for error in [None, Some(ChecksumTarget::Firmware), Some(ChecksumTarget::UserProgram)] {
        for area in [ChecksumTarget::Firmware, ChecksumTarget::UserProgram] {
            card.checksum.error = error;
            card.checksum.area = area;
            seen[pair(cfg, card.status_words(cfg))] = true;
        }
    }
    seen
}

/// The pair (bit 13, bit 12) of a status reply's words, as an index of [`engine_pairs`].
fn pair(cfg: &ModelConfig, (x, y): (u32, u32)) -> usize {
    let bit = |(word, n): (WordId, u8)| {
        let w = match word {
            WordId::X => x,
            WordId::Y => y,
        };
        usize::from(w & (1 << n) != 0)
    };
    bit(cfg.layout.checksum_error) << 1 | bit(cfg.layout.prom_checksum_active)
}

/// Whether, under `cfg`'s reading of bit 9, bit 22 set goes with bit 9 set in every word a card
/// shows. Both are set by the same RTI overrun (SRM p.289-290); under the sticky reading of
/// bit 9 (SRM p.290: "this bit is set ... and stays set until the card is reset") nothing but
/// a reset clears bit 9, while bit 22 is cleared by a reset or a host's write (SRM p.289). So
/// a word with bit 22 and without bit 9 is no sticky card's, whatever its timing or
/// tolerances.
pub fn bit22_implies_bit9(cfg: &ModelConfig) -> bool {
    cfg.profile.choices.rti_warning_latch == RtiWarningLatch::Sticky
}

/// What [`first_impossible_reply`] depends on: the (bit 13, bit 12) pairs and whether bit 22
/// implies bit 9.
pub type Rules = ([bool; 4], bool);

/// The [`Rules`] of `cfg`'s readings.
pub fn rules(cfg: &ModelConfig) -> Rules {
    (engine_pairs(cfg), bit22_implies_bit9(cfg))
}

/// The event number (as the search counts them) of the first `???` reply of the capture whose
/// bits 13 and 12 no state of the checksum engine gives under `cfg`'s readings, or whose bit
/// 22 comes without bit 9 where it implies it ([`bit22_implies_bit9`]), if any.
pub fn first_impossible_reply(
    spec: &Spec,
    path: &Path,
    import: ImportAs<'_>,
    cfg: &ModelConfig,
) -> Result<Option<u64>, SpecError> {
    let possible = engine_pairs(cfg);
    let sticky = bit22_implies_bit9(cfg);
    if possible.iter().all(|p| *p) && !sticky {
        return Ok(None);
    }
    let bit = |(x, y): (u32, u32), (word, n): (WordId, u8)| {
        (match word {
            WordId::X => x,
            WordId::Y => y,
        }) & (1 << n)
            != 0
    };
    // Events counted from 1, one per step, as `search::Reader` counts them.
    let mut source = Source::open_with(spec, path, import)?;
    let mut events = 0u64;
    while let Some((_, step)) = source.next_step()? {
        events += 1;
        if let Some(Ok(StatusReply::Words { x, y })) = step.expect.reply.as_deref().map(reply_text::decode) {
            let overrun_without_warning =
                sticky && bit((x, y), cfg.layout.rti_reentry) && !bit((x, y), cfg.layout.rti_warning);
            if !possible[pair(cfg, (x, y))] || overrun_without_warning {
                return Ok(Some(events));
            }
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::profiles::{Bit12Meaning, Profile};

    fn cfg(meaning: Bit12Meaning) -> ModelConfig {
        let spec = Spec::embedded().unwrap();
        let mut choices = spec.profiles.default_profile().choices;
        choices.bit12_meaning = meaning;
        ModelConfig::from_spec(&spec, "host-log", &Profile { name: String::new(), choices }).unwrap()
    }

    #[test]
    fn under_the_sticky_reading_of_bit_9_the_model_never_shows_bit_22_without_it() {
        // Checked on the model, not argued: an overrun, the host's clear of bit 22, more
        // cycles under a light load.
        use pmacwd_specs::vocab::event::Event;
        let spec = Spec::embedded().unwrap();
        for latch in [RtiWarningLatch::Level, RtiWarningLatch::Sticky] {
            let mut choices = spec.profiles.default_profile().choices;
            choices.rti_warning_latch = latch;
            let cfg = ModelConfig::from_spec(&spec, "host-log", &Profile { name: String::new(), choices }).unwrap();
            let mut card = Controller::power_on(&cfg);
            card.apply(&cfg, &Event::Load(crate::explain::sim::overrun_load(&cfg, card.i8)));
            let mut seen_without = false;
            for step in 0..200 {
                if step == 100 {
                    card.apply(&cfg, &Event::Load(crate::explain::sim::light_load()));
                }
                card.servo_cycle(&cfg);
                let (x, y) = card.status_words(&cfg);
                let on = |(w, n): (WordId, u8)| (if w == WordId::X { x } else { y }) & (1 << n) != 0;
                seen_without |= on(cfg.layout.rti_reentry) && !on(cfg.layout.rti_warning);
            }
            assert_eq!(seen_without, !bit22_implies_bit9(&cfg), "{latch:?}");
        }
    }

    #[test]
    fn under_m83_bit_12_without_bit_13_is_no_state_of_the_engine_and_every_pair_is_one_under_srm_p289() {
        // SRM p.289: bit 12 is the area (evaluating or in error), any pair occurs.
        assert_eq!(engine_pairs(&cfg(Bit12Meaning::PromChecksumActive)), [true; 4]);
        // M83: bit 12 is the firmware error bit, so it implies bit 13 (any error).
        assert_eq!(engine_pairs(&cfg(Bit12Meaning::FirmwareChecksumError)), [true, false, true, true]);
    }
}
