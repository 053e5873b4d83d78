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

use crate::replay::{ImportAs, Source};
use pmacwd_model::controller::Controller;
use pmacwd_specs::check::ChecksumTarget;
use pmacwd_specs::config::ModelConfig;
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

/// The event number (as the search counts them) of the first `???` reply of the capture whose
/// bits 13 and 12 no state of the checksum engine gives under `cfg`'s readings, if any.
pub fn first_impossible_reply(
    spec: &Spec,
    path: &Path,
    import: ImportAs<'_>,
    cfg: &ModelConfig,
) -> Result<Option<u64>, SpecError> {
    let possible = engine_pairs(cfg);
    if possible.iter().all(|p| *p) {
        return Ok(None);
    }
    // Events counted from 1, one per step, as `search::Reader` counts them.
    let mut source = Source::open_with(spec, path, import)?;
    let mut events = 0u64;
    while let Some((_, step)) = source.next_step()? {
        events += 1;
        if let Some(Ok(StatusReply::Words { x, y })) = step.expect.reply.as_deref().map(reply_text::decode) {
            if !possible[pair(cfg, (x, y))] {
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
    fn under_m83_bit_12_without_bit_13_is_no_state_of_the_engine_and_every_pair_is_one_under_srm_p289() {
        // SRM p.289: bit 12 is the area (evaluating or in error), any pair occurs.
        assert_eq!(engine_pairs(&cfg(Bit12Meaning::PromChecksumActive)), [true; 4]);
        // M83: bit 12 is the firmware error bit, so it implies bit 13 (any error).
        assert_eq!(engine_pairs(&cfg(Bit12Meaning::FirmwareChecksumError)), [true, false, true, true]);
    }
}
