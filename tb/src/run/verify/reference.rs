//! The reference: one plain unbounded stack per thread.

/// An unbounded LIFO of node addresses.
#[derive(Debug, Default, PartialEq, Eq, Hash)]
pub struct RefStack(Vec<u64>);

/// `clone_from` keeps the allocation (the exhaustive search clones a model per transition).
impl Clone for RefStack {
    fn clone(&self) -> Self {
        RefStack(self.0.clone())
    }
    fn clone_from(&mut self, src: &Self) {
        self.0.clone_from(&src.0);
    }
}

impl RefStack {
    pub fn push(&mut self, v: u64) {
        self.0.push(v);
    }
    pub fn pop(&mut self) -> Option<u64> {
        self.0.pop()
    }
    pub fn len(&self) -> usize {
        self.0.len()
    }
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    /// Forgets every entry (a restart design answered Restart: it had dropped them all).
    pub fn clear(&mut self) {
        self.0.clear();
    }
    /// Entries, newest first.
    pub fn top_first(&self) -> impl Iterator<Item = u64> + '_ {
        self.0.iter().rev().copied()
    }
}
