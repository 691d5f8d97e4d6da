//! The register arrays as the cycle description ([`cycle`]) sees them: read as the cycle began
//! ([`Registers`]) and written at the clock edge ([`Store`]). The only code that maps the
//! description's register names onto the manager's arrays.

use super::*;

/// The registers as the cycle began, for [`cycle::eval`].
impl Registers<Int> for StackManager {
    #[inline]
    fn stack_q(&self, _: &mut Int, s: u32) -> StackRegs {
        // A stack past the array reads as reset registers; the cycle is then refused
        // ([`StackManager::addressed`]) or its decisions differ from the scoreboard's.
        self.stacks.get(s as usize).copied().unwrap_or_default()
    }
    #[inline]
    fn thread_q(&self, _: &mut Int, t: u32) -> ThreadRegs {
        self.threads[t as usize]
    }
    fn done_q(&self, _: &mut Int, s: u32) -> bool {
        self.threads.get(s as usize).is_none_or(|t| t.done)
    }
    #[inline]
    fn busy_q(&self, _: &mut Int, t: u32) -> bool {
        !self.ready(t)
    }
    #[inline]
    fn inflight_q(&self, t: u32) -> Option<Uop> {
        self.seq[t as usize].inflight
    }
    #[inline]
    fn head_q(&self, t: u32) -> Option<Uop> {
        self.seq[t as usize].uops.front().copied()
    }
    #[inline]
    fn latch_q(&self, t: u32) -> Option<Entry> {
        self.seq[t as usize].latch
    }
    fn rb_len_q(&self, _: &mut Int, t: u32) -> u32 {
        self.rb[t as usize].len() as u32
    }
    fn rb_front_q(&self, _: &mut Int, t: u32) -> Entry {
        self.rb[t as usize].front().copied().unwrap_or(POISON)
    }
    fn rb_back_q(&self, _: &mut Int, t: u32) -> Entry {
        self.rb[t as usize].back().copied().unwrap_or(POISON)
    }
    fn sh_q(&self, _: &mut Int, stack: u32, entry: u32) -> Entry {
        let i = stack.checked_mul(self.cfg.sh_entries).and_then(|x| x.checked_add(entry));
        i.and_then(|i| self.sh_data.get(i as usize)).copied().unwrap_or(POISON)
    }
    fn global_q(&self, _: &mut Int, t: u32, slot: u32) -> Entry {
        self.global[t as usize].get(slot as usize).copied().unwrap_or(POISON)
    }
    #[inline]
    fn next_queued(&self, from: u32) -> Option<u32> {
        let mut word = (from / 64) as usize;
        let mut bits = self.queued.get(word)? & (u64::MAX << (from % 64));
        loop {
            if bits != 0 {
                return Some(word as u32 * 64 + bits.trailing_zeros());
            }
            word += 1;
            bits = *self.queued.get(word)?;
        }
    }
    fn acked_stores(&self) -> bool {
        self.acked_stores
    }
}

/// The clock edge's writes, for [`cycle::apply`].
impl Store<Int> for StackManager {
    #[inline]
    fn set_stack(&mut self, _: &mut Int, s: u32, r: Regs<Int>) {
        self.stacks[s as usize] = r;
    }
    #[inline]
    fn set_thread(&mut self, t: u32, r: Thread<Int>) {
        self.threads[t as usize] = r;
    }
    #[inline]
    fn rb(&mut self, _: &mut Int, t: u32, op: RbOp<Entry>) {
        let rb = &mut self.rb[t as usize];
        match op {
            RbOp::PushBack(v) => rb.push_back(v),
            RbOp::PopBack => {
                rb.pop_back();
            }
            RbOp::PopFront => {
                rb.pop_front();
            }
        }
    }
    fn rb_push_front(&mut self, _: &mut Int, t: u32, v: Entry) {
        self.rb[t as usize].push_front(v);
    }
    fn sh(&mut self, _: &mut Int, stack: u32, entry: u32, v: Entry) {
        let i = self.sh_index(stack, entry);
        self.sh_data[i] = v;
    }
    fn global(&mut self, _: &mut Int, t: u32, slot: u32, v: Entry) {
        let g = &mut self.global[t as usize];
        if g.len() <= slot as usize {
            g.resize(slot as usize + 1, POISON);
        }
        g[slot as usize] = v;
    }
    #[inline]
    fn seq(&mut self, t: u32, issued: bool, inflight: Option<Uop>, latch: Option<Entry>) {
        let q = &mut self.seq[t as usize];
        if issued {
            q.uops.pop_front();
        }
        (q.inflight, q.latch) = (inflight, latch);
        self.sync_queued(t);
    }
    #[inline]
    fn emit(&mut self, _: &mut Int, t: u32, valid: bool, u: Uop) {
        if valid {
            self.seq[t as usize].uops.push_back(u);
            self.sync_queued(t);
        }
    }
}
