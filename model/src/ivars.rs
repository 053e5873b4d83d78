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
}
