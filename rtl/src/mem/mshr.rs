//! Miss status holding registers: one entry per missed sector (or line) in flight, each holding
//! the requests waiting for it.
//!
//! ```text
//!   miss(key) ─► entry for key? ── yes, room ─► Merge    (no new downstream request)
//!                               ── yes, full ─► Full     (stall)
//!                               ── no, free  ─► Allocate (one downstream request)
//!                               ── no, none  ─► Full     (stall)
//!   fill(key) ─► release: every waiter of key, oldest first; the entry frees
//! ```
//!
//! Entries live in a hash map that is never iterated (every access names its key), so nothing
//! depends on hash order; released waiter lists are kept for reuse, so a miss allocates nothing
//! once the table has been that full before. The table is RAM-like state of
//! its owner (an L1D or the L2): [`Mshr::check`] is a pure read, used by the owner's `eval`;
//! [`Mshr::insert`] and [`Mshr::release_each`] are the write port, used only by the owner's `commit`.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use super::cache::LineHasher;

/// A request waiting for a fill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Waiter {
    /// Which requester (SM) to answer; 0 where there is only one.
    pub port: u32,
    pub id: u64,
    pub addr: u64,
}

/// What a miss to a key would do now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Merge,
    Allocate,
    /// No free entry, or the key's entry has no room for another waiter: stall.
    Full,
}

#[derive(Clone, Debug)]
pub struct Mshr {
    entries: HashMap<u64, Vec<Waiter>, BuildHasherDefault<LineHasher>>,
    /// Emptied waiter lists, reused by the next allocations (no allocation per miss).
    spare: Vec<Vec<Waiter>>,
    capacity: usize,
    max_merge: usize,
}

impl Mshr {
    /// `capacity` entries of up to `max_merge` waiters each.
    pub fn new(capacity: u32, max_merge: u32) -> Mshr {
        Mshr {
            entries: HashMap::default(),
            spare: Vec::new(),
            capacity: capacity as usize,
            max_merge: max_merge as usize,
        }
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    pub fn contains(&self, key: u64) -> bool {
        self.entries.contains_key(&key)
    }

    /// Pure: what [`Mshr::insert`] of a miss to `key` would do.
    pub fn check(&self, key: u64) -> Outcome {
        match self.entries.get(&key) {
            Some(w) if w.len() < self.max_merge => Outcome::Merge,
            Some(_) => Outcome::Full,
            None if self.entries.len() < self.capacity => Outcome::Allocate,
            None => Outcome::Full,
        }
    }

    /// Records a miss; on `Full` nothing changes.
    pub fn insert(&mut self, key: u64, waiter: Waiter) -> Outcome {
        // One index lookup for both the check and the update ([`Mshr::check`]'s outcomes).
        let room = self.entries.len() < self.capacity;
        match self.entries.entry(key) {
            Entry::Occupied(mut e) if e.get().len() < self.max_merge => {
                e.get_mut().push(waiter);
                Outcome::Merge
            }
            Entry::Vacant(e) if room => {
                let mut list = self.spare.pop().unwrap_or_default();
                list.push(waiter);
                e.insert(list);
                Outcome::Allocate
            }
            _ => Outcome::Full,
        }
    }

    /// The fill for `key` arrived: frees its entry and returns its waiters, oldest first (the
    /// tests' form of [`Mshr::release_each`]).
    #[cfg(test)]
    pub fn release(&mut self, key: u64) -> Vec<Waiter> {
        let mut out = Vec::new();
        self.release_each(key, |w| out.push(*w));
        out
    }

    /// The fill for `key` arrived: frees its entry; `f` sees each of its waiters, oldest first.
    /// Allocates nothing (the emptied list is kept for the next allocation).
    pub fn release_each(&mut self, key: u64, f: impl FnMut(&Waiter)) {
        if let Some(mut list) = self.entries.remove(&key) {
            list.iter().for_each(f);
            list.clear();
            self.spare.push(list);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::testutil::XorShift;

    fn w(id: u64) -> Waiter {
        Waiter { port: 0, id, addr: id * 4 }
    }

    #[test]
    fn same_key_merges_and_releases_all_in_order() {
        let mut m = Mshr::new(2, 4);
        assert_eq!(m.insert(0x40, w(1)), Outcome::Allocate);
        assert_eq!(m.insert(0x40, w(2)), Outcome::Merge);
        assert_eq!(m.len(), 1);
        assert_eq!(m.release(0x40), vec![w(1), w(2)]);
        assert!(m.is_empty());
        assert_eq!(m.release(0x40), vec![]);
    }

    #[test]
    fn full_table_and_full_entry_stall() {
        let mut m = Mshr::new(2, 2);
        m.insert(0, w(1));
        m.insert(32, w(2));
        assert_eq!(m.check(64), Outcome::Full);
        assert_eq!(m.insert(64, w(3)), Outcome::Full);
        assert!(!m.contains(64));
        assert_eq!(m.insert(0, w(4)), Outcome::Merge);
        assert_eq!(m.insert(0, w(5)), Outcome::Full, "merge limit");
        m.release(32);
        assert_eq!(m.insert(64, w(3)), Outcome::Allocate);
    }

    /// Random inserts and releases against a list-of-lists reference.
    fn compare(seed: u64, planted_merge_limit_off: bool) -> Result<(), String> {
        let (cap, merge) = (4usize, 3usize);
        let mut m = Mshr::new(cap as u32, merge as u32);
        let mut r: Vec<(u64, Vec<u64>)> = Vec::new();
        let mut rng = XorShift(seed);
        for step in 0..3000u64 {
            let key = rng.below(8) * 32;
            if rng.below(3) == 0 {
                let got: Vec<u64> = m.release(key).iter().map(|w| w.id).collect();
                let want = r.iter().position(|(k, _)| *k == key).map(|i| r.remove(i).1).unwrap_or_default();
                if got != want {
                    return Err(format!("step {step}: released {got:?} vs {want:?}"));
                }
            } else {
                let held = r.len();
                let want = match r.iter_mut().find(|(k, _)| *k == key) {
                    Some((_, ws)) if ws.len() < merge || planted_merge_limit_off => {
                        ws.push(step);
                        Outcome::Merge
                    }
                    Some(_) => Outcome::Full,
                    None if held < cap => {
                        r.push((key, vec![step]));
                        Outcome::Allocate
                    }
                    None => Outcome::Full,
                };
                let got = m.insert(key, w(step));
                if got != want {
                    return Err(format!("step {step}: {got:?} vs {want:?}"));
                }
            }
        }
        Ok(())
    }

    #[test]
    fn matches_reference() {
        for seed in 1..=8 {
            compare(seed, false).unwrap();
        }
    }

    #[test]
    fn checker_catches_a_reference_without_merge_limit() {
        assert!(compare(1, true).is_err());
    }
}
