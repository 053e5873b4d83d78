//! Cards as the keys of the search's maps: compared whole, hashed by the few fields that tell
//! the search's cards apart.
//!
//! The model's derived `Hash` walks every field of a card, its eight motors and sixteen
//! program slots included, which a host log's cards share: a fifth of a long replay went to
//! it (issue 32). Hashing a part of what `Eq` compares keeps the two consistent (equal cards
//! hash alike); cards that differ only elsewhere share a bucket and are told apart by `Eq`.

use pmacwd_model::controller::Controller;
use std::hash::{Hash, Hasher};

/// A card as a map key.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CardKey(pub Controller);

impl Hash for CardKey {
    fn hash<H: Hasher>(&self, h: &mut H) {
        let c = &self.0;
        c.counter.hash(h);
        c.counter_min.hash(h);
        c.cycles_since_strobe.hash(h);
        c.rti_phase.hash(h);
        c.rti_remaining.hash(h);
        c.background_credit.hash(h);
        c.trip.hash(h);
        c.load.hash(h);
        c.status.hash(h);
        c.checksum.hash(h);
        c.i40.hash(h);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::config::ModelConfig;
    use pmacwd_specs::Spec;
    use std::hash::BuildHasher;

    #[test]
    fn equal_cards_hash_alike_and_cards_differing_outside_the_hashed_fields_stay_apart() {
        let spec = Spec::embedded().unwrap();
        let profile = spec.profiles.all().remove(0);
        let cfg = ModelConfig::from_spec(&spec, "host-log", &profile).unwrap();
        let a = Controller::power_on(&cfg);
        let hasher = foldhash::fast::FixedState::default();
        assert_eq!(hasher.hash_one(CardKey(a.clone())), hasher.hash_one(CardKey(a.clone())));
        let mut b = a.clone();
        b.i41 = 3;
        let mut map = std::collections::HashMap::with_hasher(hasher);
        map.insert(CardKey(a), 1);
        map.insert(CardKey(b), 2);
        assert_eq!(map.len(), 2);
    }
}
