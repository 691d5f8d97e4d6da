//! The RT unit's warp scheduler: greedy-then-oldest (GTO), or oldest-first (`[rt] warp_select`).
//!
//! ```text
//!  per warp: fetchable lanes ≠ 0 (ready), age rank ──► GTO: greedy warp if ready, else the
//!  oldest ready warp; oldest: the oldest ready warp ──► issue (warp, lanes) to node fetch;
//!  greedy ← issued warp (clock edge)
//! ```
//!
//! It picks in the cycle the node-fetch queue drains (the port taking the last piece is the
//! queue's ready signal). A warp that leaves stops being the greedy one.
//!
//! Why two policies: the paper names GTO for the RT unit (§II-B and its configuration table);
//! Vulkan-Sim's public `rt_unit::schedule_next_warp` (`src/gpgpu-sim/shader.cc:3217-3230`)
//! takes the first non-stalled warp of a map ordered by warp uid, i.e. the oldest, and
//! `rt_unit::cycle` calls it again for every new access (`shader.cc:3058-3061`). Here both pick
//! when the fetch queue drains, so `Oldest` differs from GTO only in dropping the greedy warp.

use crate::config::Widths;
use crate::trace::{Kind, Sink};

/// How the scheduler picks among warps with lanes ready to fetch (`[rt] warp_select`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum WarpSelect {
    /// Greedy-then-oldest: keep the warp issued last while it is ready (the paper's, default).
    #[default]
    Gto,
    /// The oldest ready warp at every pick (Vulkan-Sim's public `schedule_next_warp`).
    Oldest,
}

named_enum!(WarpSelect, WarpSelect::Gto => "gto", WarpSelect::Oldest => "oldest");

/// Greedy-then-oldest: the warp issued last if it is `ready`, else the ready warp of lowest `age`.
#[inline]
pub fn gto(
    greedy: Option<u32>,
    warps: u32,
    ready: impl Fn(u32) -> bool,
    age: impl Fn(u32) -> u32,
) -> Option<u32> {
    greedy.filter(|&w| ready(w)).or_else(|| (0..warps).filter(|&w| ready(w)).min_by_key(|&w| age(w)))
}

/// Registers of the scheduler.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct WarpScheduler {
    /// The warp issued last.
    greedy: Option<u32>,
}

impl WarpScheduler {
    /// The warp to issue this cycle among `warps` under `select`, combinational. `left`: a warp
    /// leaving this cycle (no longer greedy).
    #[inline]
    pub fn pick(
        &self,
        select: WarpSelect,
        left: impl Fn(u32) -> bool,
        warps: u32,
        ready: impl Fn(u32) -> bool,
        age: impl Fn(u32) -> u32,
    ) -> Option<u32> {
        let greedy = match select {
            WarpSelect::Gto => self.greedy.filter(|&w| !left(w)),
            WarpSelect::Oldest => None,
        };
        gto(greedy, warps, ready, age)
    }

    /// The clock edge: the issued warp becomes the greedy one; a leaving greedy warp is dropped.
    #[inline]
    pub fn commit(&mut self, issued: Option<u32>, left: impl Fn(u32) -> bool) {
        self.greedy = issued.or(self.greedy.filter(|&w| !left(w)));
    }

    /// Registers and this cycle's issue (`(warp, lanes)`).
    pub fn probe<S: Sink>(&self, issue: Option<(u32, u32)>, w: &Widths, warp_size: u32, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("scheduler");
        s.signal("greedy_valid", 1, u64::from(self.greedy.is_some()));
        s.signal("greedy", w.warp, u64::from(self.greedy.unwrap_or(0)));
        s.signal("issue_valid", 1, u64::from(issue.is_some()));
        s.signal("issue_warp", w.warp, u64::from(issue.map_or(0, |i| i.0)));
        s.signal_kind("issue_lanes", warp_size, u64::from(issue.map_or(0, |i| i.1)), Kind::Mask);
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gto_keeps_the_greedy_warp_then_takes_the_oldest() {
        let ages = [3, 1, 2, 0];
        let age = |w: u32| ages[w as usize];
        let ready_mask = |m: u32| move |w: u32| m & (1 << w) != 0;
        assert_eq!(gto(Some(2), 4, ready_mask(0b1111), age), Some(2), "greedy while ready");
        assert_eq!(gto(Some(2), 4, ready_mask(0b1011), age), Some(3), "stalled: oldest ready");
        assert_eq!(gto(None, 4, ready_mask(0b0011), age), Some(1));
        assert_eq!(gto(Some(0), 4, ready_mask(0), age), None);
        let mut s = WarpScheduler::default();
        s.commit(Some(2), |_| false);
        let gto = WarpSelect::Gto;
        assert_eq!(
            s.pick(gto, |w| w == 2, 4, ready_mask(0b1111), age),
            Some(3),
            "a leaving warp is not greedy"
        );
        s.commit(None, |w| w == 2);
        assert_eq!(s, WarpScheduler::default());
    }

    #[test]
    fn oldest_first_drops_the_greedy_warp() {
        let ages = [3, 1, 2, 0];
        let age = |w: u32| ages[w as usize];
        let all = |_: u32| true;
        let mut s = WarpScheduler::default();
        s.commit(Some(2), |_| false);
        assert_eq!(s.pick(WarpSelect::Gto, |_| false, 4, all, age), Some(2), "GTO stays on warp 2");
        assert_eq!(s.pick(WarpSelect::Oldest, |_| false, 4, all, age), Some(3), "oldest: warp 3 (age 0)");
        let not_3 = |w: u32| w != 3;
        assert_eq!(s.pick(WarpSelect::Oldest, |_| false, 4, not_3, age), Some(1), "the oldest ready one");
    }
}
