//! The I-variables the model stores without giving them a rule: every one written since reset
//! with a value other than 0 (all read 0 otherwise), kept in order of their numbers.
//!
//! A sorted `Vec` rather than a `BTreeMap`: the checker clones and drops the controller on every
//! transition, and an empty `BTreeMap`'s drop still walks its (absent) tree, about 180
//! instructions per checked state on `timing` (callgrind), where an empty `Vec`'s is a test of
//! its capacity. Writes are rare and few, so the linear insert costs nothing that shows.

/// I-variable numbers with their values, sorted by number, no zero values. Ordered as the
/// `BTreeMap` was (its entries compared in turn), which the states' order relies on.
#[derive(Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct IVariables(Vec<(u16, i64)>);

impl Clone for IVariables {
    /// The empty case first, inline: nearly every state the checker clones has no such
    /// I-variable, and `Vec::clone` of an empty vector still goes through the allocator's
    /// bookkeeping out of line.
    #[inline]
    fn clone(&self) -> IVariables {
        if self.0.is_empty() {
            IVariables(Vec::new())
        } else {
            IVariables(self.0.clone())
        }
    }

    /// In place, the buffer kept: the checker's leaps copy the controller into the same
    /// buffer every servo cycle (`Controller::clone_from`).
    #[inline]
    fn clone_from(&mut self, source: &IVariables) {
        if source.0.is_empty() {
            self.0.clear();
        } else {
            self.0.clone_from(&source.0);
        }
    }
}

impl IVariables {
    pub fn new() -> IVariables {
        IVariables(Vec::new())
    }

    pub fn get(&self, n: &u16) -> Option<&i64> {
        self.0.binary_search_by_key(n, |(k, _)| *k).ok().map(|i| &self.0[i].1)
    }

    /// Sets I`n` to `v`, as `BTreeMap::insert` would.
    pub fn insert(&mut self, n: u16, v: i64) {
        match self.0.binary_search_by_key(&n, |(k, _)| *k) {
            Ok(i) => self.0[i].1 = v,
            Err(i) => self.0.insert(i, (n, v)),
        }
    }

    pub fn remove(&mut self, n: &u16) {
        if let Ok(i) = self.0.binary_search_by_key(n, |(k, _)| *k) {
            self.0.remove(i);
        }
    }

    pub fn clear(&mut self) {
        self.0.clear();
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// In increasing order of the I-variable number.
    pub fn iter(&self) -> impl Iterator<Item = (&u16, &i64)> {
        self.0.iter().map(|(n, v)| (n, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// The same sequence of writes and removals leaves this and a `BTreeMap` holding the same
    /// entries in the same order: the replacement behaves as the map it replaced.
    #[test]
    fn behaves_as_the_btree_map_it_replaced() {
        let mut ours = IVariables::new();
        let mut map = BTreeMap::new();
        let mut x: u32 = 12345;
        for _ in 0..2000 {
            // A small linear congruential sequence over 40 numbers, so that keys repeat.
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let n = ((x >> 16) % 40) as u16;
            if x & 1 == 0 {
                ours.insert(n, i64::from(x >> 8));
                map.insert(n, i64::from(x >> 8));
            } else {
                ours.remove(&n);
                map.remove(&n);
            }
            assert_eq!(
                ours.iter().map(|(k, v)| (*k, *v)).collect::<Vec<_>>(),
                map.iter().map(|(k, v)| (*k, *v)).collect::<Vec<_>>()
            );
            assert_eq!(ours.get(&n), map.get(&n));
            assert_eq!(ours.len(), map.len());
        }
    }

    /// `clone_from` copies into the buffer it has: an empty source leaves it allocated (the
    /// derived one dropped it), and a full one is copied whole.
    #[test]
    fn clone_from_keeps_the_buffer_and_copies_the_entries() {
        let mut full = IVariables::new();
        full.insert(130, 7);
        full.insert(5100, -2);
        let mut target = full.clone();
        target.clone_from(&IVariables::new());
        assert!(target.is_empty());
        assert!(target.0.capacity() > 0, "the buffer is kept");
        target.clone_from(&full);
        assert_eq!(target, full);
    }

    /// The controller's hand-written `clone_from` gives what `clone` gives, from states that
    /// differ in every part: a leap copies the controller with it every servo cycle.
    #[test]
    fn controller_clone_from_equals_clone() {
        use crate::controller::Controller;
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let mut states = Vec::new();
        for name in ["timing", "motion", "lockout", "i40-zero"] {
            let cfg =
                pmacwd_specs::config::ModelConfig::from_spec(&spec, name, &spec.profiles.default_profile()).unwrap();
            let mut c = Controller::power_on(&cfg);
            states.push(c.clone());
            for _ in 0..5 {
                c.servo_cycle(&cfg);
            }
            c.other_i_variables.insert(130, 3);
            c.axes.motor_slots[1].state = pmacwd_specs::vocab::MotorState::Jogging;
            c.ghost.recovered_by = Some(pmacwd_specs::check::ResetKind::Power);
            states.push(c);
        }
        for a in &states {
            for b in &states {
                let mut target = a.clone();
                target.clone_from(b);
                assert_eq!(&target, b);
                assert_eq!(&b.clone(), b);
            }
        }
    }
}
