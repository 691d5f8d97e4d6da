//! The reference: one plain unbounded stack per thread.

/// An unbounded LIFO of node addresses.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct RefStack(Vec<u64>);

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
    /// Entries, newest first.
    pub fn top_first(&self) -> impl Iterator<Item = u64> + '_ {
        self.0.iter().rev().copied()
    }
}
