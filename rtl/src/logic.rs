//! The word/bit abstraction the stack manager's decision logic is written over, so that one
//! description both simulates and is proved.
//!
//! A [`Logic`] supplies 32-bit unsigned words (wrapping arithmetic, unsigned compares), bits,
//! 64-bit entry values and multiplexers. [`Int`] instantiates it with plain `u32`/`bool`/`u64`:
//! every operation is the Rust operator, inlined, so the simulator runs the logic at full speed.
//! A symbolic instance (the `sms prove` tool's SMT term builder) turns the same code into the
//! transition relation an SMT solver checks, the way yosys turns Verilog into SMT.
//!
//! Control flow: a branch on a value is [`Logic::decide`] (the simulator takes the branch the
//! value says; a symbolic instance explores both, one path at a time, under a path condition).
//! Work that only matters when a bit is set is skipped when [`Logic::maybe`] says the bit cannot
//! be set (the simulator skips it exactly when the bit is false; a symbolic instance does it
//! under a multiplexer). Loops over data-dependent lengths run to a fixed bound and stop early
//! only when `maybe` allows, so every instance computes the same function.

use std::fmt::Debug;

/// Words, bits and entry values, with the operators the stack manager's logic uses.
pub trait Logic {
    type Bit: Copy + Debug;
    type Word: Copy + Debug;
    /// A stack entry (a node address, 64 bits). The logic only moves entries, never computes
    /// with them.
    type Val: Copy + Debug;

    fn bit(&mut self, b: bool) -> Self::Bit;
    fn word(&mut self, w: u32) -> Self::Word;
    fn val(&mut self, v: u64) -> Self::Val;

    fn not(&mut self, a: Self::Bit) -> Self::Bit;
    fn and(&mut self, a: Self::Bit, b: Self::Bit) -> Self::Bit;
    fn or(&mut self, a: Self::Bit, b: Self::Bit) -> Self::Bit;

    /// Wrapping 32-bit sum.
    fn add(&mut self, a: Self::Word, b: Self::Word) -> Self::Word;
    /// Wrapping 32-bit difference.
    fn sub(&mut self, a: Self::Word, b: Self::Word) -> Self::Word;
    /// Unsigned quotient; `b` is never 0 where the logic divides.
    fn div(&mut self, a: Self::Word, b: Self::Word) -> Self::Word;
    /// Unsigned remainder; `b` is never 0 where the logic divides.
    fn rem(&mut self, a: Self::Word, b: Self::Word) -> Self::Word;
    /// Bitwise and (a register narrower than 32 bits keeps only its low bits).
    fn mask(&mut self, a: Self::Word, b: Self::Word) -> Self::Word;

    fn eq(&mut self, a: Self::Word, b: Self::Word) -> Self::Bit;
    /// Unsigned `a < b`.
    fn lt(&mut self, a: Self::Word, b: Self::Word) -> Self::Bit;
    fn eq_val(&mut self, a: Self::Val, b: Self::Val) -> Self::Bit;

    /// `c ? a : b`.
    fn mux(&mut self, c: Self::Bit, a: Self::Word, b: Self::Word) -> Self::Word;
    fn mux_bit(&mut self, c: Self::Bit, a: Self::Bit, b: Self::Bit) -> Self::Bit;
    fn mux_val(&mut self, c: Self::Bit, a: Self::Val, b: Self::Val) -> Self::Val;

    /// A branch of the control flow on `c`: which way this execution goes.
    fn decide(&mut self, c: Self::Bit) -> bool;
    /// False only if `c` is certainly false (work guarded by `c` may then be skipped).
    fn maybe(&mut self, c: Self::Bit) -> bool;

    /// `a` and `b` are certainly the same word (a write to one may replace a write to the
    /// other); false when unknown.
    fn same(&self, a: Self::Word, b: Self::Word) -> bool;
    /// Every word is a known value: [`Logic::same`] is equality.
    fn exact(&self) -> bool;
    /// The word's value where it is known, else 0 (for messages only, never for decisions).
    fn concrete(&self, w: Self::Word) -> u32;

    // ---- derived operators ------------------------------------------------------------------

    fn ne(&mut self, a: Self::Word, b: Self::Word) -> Self::Bit {
        let e = self.eq(a, b);
        self.not(e)
    }
    /// Unsigned `a <= b`.
    fn le(&mut self, a: Self::Word, b: Self::Word) -> Self::Bit {
        let g = self.lt(b, a);
        self.not(g)
    }
    fn add_k(&mut self, a: Self::Word, k: u32) -> Self::Word {
        let k = self.word(k);
        self.add(a, k)
    }
    fn sub_k(&mut self, a: Self::Word, k: u32) -> Self::Word {
        let k = self.word(k);
        self.sub(a, k)
    }
    fn eq_k(&mut self, a: Self::Word, k: u32) -> Self::Bit {
        let k = self.word(k);
        self.eq(a, k)
    }
    fn lt_k(&mut self, a: Self::Word, k: u32) -> Self::Bit {
        let k = self.word(k);
        self.lt(a, k)
    }
    /// 1 when `b`, else 0.
    fn count(&mut self, b: Self::Bit) -> Self::Word {
        let (one, zero) = (self.word(1), self.word(0));
        self.mux(b, one, zero)
    }
}

/// The simulator's instance: plain integers, every operator inlined.
#[derive(Clone, Copy, Debug, Default)]
pub struct Int;

impl Logic for Int {
    type Bit = bool;
    type Word = u32;
    type Val = u64;

    #[inline(always)]
    fn bit(&mut self, b: bool) -> bool {
        b
    }
    #[inline(always)]
    fn word(&mut self, w: u32) -> u32 {
        w
    }
    #[inline(always)]
    fn val(&mut self, v: u64) -> u64 {
        v
    }
    #[inline(always)]
    fn not(&mut self, a: bool) -> bool {
        !a
    }
    #[inline(always)]
    fn and(&mut self, a: bool, b: bool) -> bool {
        a && b
    }
    #[inline(always)]
    fn or(&mut self, a: bool, b: bool) -> bool {
        a || b
    }
    #[inline(always)]
    fn add(&mut self, a: u32, b: u32) -> u32 {
        a.wrapping_add(b)
    }
    #[inline(always)]
    fn sub(&mut self, a: u32, b: u32) -> u32 {
        a.wrapping_sub(b)
    }
    #[inline(always)]
    fn div(&mut self, a: u32, b: u32) -> u32 {
        a / b
    }
    #[inline(always)]
    fn rem(&mut self, a: u32, b: u32) -> u32 {
        a % b
    }
    #[inline(always)]
    fn mask(&mut self, a: u32, b: u32) -> u32 {
        a & b
    }
    #[inline(always)]
    fn eq(&mut self, a: u32, b: u32) -> bool {
        a == b
    }
    #[inline(always)]
    fn lt(&mut self, a: u32, b: u32) -> bool {
        a < b
    }
    #[inline(always)]
    fn eq_val(&mut self, a: u64, b: u64) -> bool {
        a == b
    }
    #[inline(always)]
    fn mux(&mut self, c: bool, a: u32, b: u32) -> u32 {
        if c {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn mux_bit(&mut self, c: bool, a: bool, b: bool) -> bool {
        if c {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn mux_val(&mut self, c: bool, a: u64, b: u64) -> u64 {
        if c {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn same(&self, a: u32, b: u32) -> bool {
        a == b
    }
    #[inline(always)]
    fn exact(&self) -> bool {
        true
    }
    #[inline(always)]
    fn concrete(&self, w: u32) -> u32 {
        w
    }
    #[inline(always)]
    fn decide(&mut self, c: bool) -> bool {
        c
    }
    #[inline(always)]
    fn maybe(&mut self, c: bool) -> bool {
        c
    }
}
