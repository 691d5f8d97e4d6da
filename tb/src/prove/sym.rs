//! The symbolic instance of [`Logic`]: every operation builds a node of a hash-consed term DAG
//! (constants folded), printed as SMT-LIB 2 over `(_ BitVec 32)` words, `Bool` bits and
//! `(_ BitVec 64)` entry values, the same widths the simulator's `u32`/`bool`/`u64` have, so the
//! solver checks exactly the arithmetic the simulator runs.
//!
//! [`Logic::decide`] forks: an execution follows a script of branch decisions and records the
//! path condition; [`Sym::explore`] enumerates every path depth first.

use std::collections::HashMap;
use std::fmt::Write as _;

use rtl::logic::Logic;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Sort {
    Bool,
    Word,
    Val,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum Node {
    Bool(bool),
    Word(u32),
    Val(u64),
    Var(Sort, String),
    Not(u32),
    And(u32, u32),
    Or(u32, u32),
    Add(u32, u32),
    Sub(u32, u32),
    Div(u32, u32),
    Rem(u32, u32),
    Mask(u32, u32),
    /// Logical shift right by a constant.
    Shr(u32, u32),
    Eq(u32, u32),
    Lt(u32, u32),
    Ite(Sort, u32, u32, u32),
}

/// A term of sort Bool.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct B(pub u32);
/// A term of sort `(_ BitVec 32)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct W(pub u32);
/// A term of sort `(_ BitVec 64)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct V(pub u32);

/// The term builder and the current execution's branch script.
#[derive(Default)]
pub struct Sym {
    nodes: Vec<Node>,
    memo: HashMap<Node, u32>,
    /// Branch decisions of the execution being explored, and how many it has taken.
    script: Vec<bool>,
    cursor: usize,
    /// The path condition so far: one literal per decision on a non-constant bit.
    path: Vec<B>,
    vars: Vec<(u32, Sort, String)>,
}

impl Sym {
    fn mk(&mut self, n: Node) -> u32 {
        if let Some(&i) = self.memo.get(&n) {
            return i;
        }
        let i = self.nodes.len() as u32;
        self.nodes.push(n.clone());
        self.memo.insert(n, i);
        i
    }

    /// A fresh variable named `name` (an SMT symbol).
    fn var(&mut self, sort: Sort, name: &str) -> u32 {
        let i = self.mk(Node::Var(sort, name.to_string()));
        if !self.vars.iter().any(|v| v.0 == i) {
            self.vars.push((i, sort, name.to_string()));
        }
        i
    }
    pub fn var_bit(&mut self, name: &str) -> B {
        B(self.var(Sort::Bool, name))
    }
    pub fn var_word(&mut self, name: &str) -> W {
        W(self.var(Sort::Word, name))
    }
    pub fn var_val(&mut self, name: &str) -> V {
        V(self.var(Sort::Val, name))
    }
    /// The variables declared so far: (name, sort).
    pub fn vars(&self) -> impl Iterator<Item = (&str, Sort)> {
        self.vars.iter().map(|v| (v.2.as_str(), v.1))
    }

    fn bool_of(&self, i: u32) -> Option<bool> {
        match self.nodes[i as usize] {
            Node::Bool(b) => Some(b),
            _ => None,
        }
    }
    fn word_of(&self, i: u32) -> Option<u32> {
        match self.nodes[i as usize] {
            Node::Word(w) => Some(w),
            _ => None,
        }
    }
    fn val_of(&self, i: u32) -> Option<u64> {
        match self.nodes[i as usize] {
            Node::Val(v) => Some(v),
            _ => None,
        }
    }

    /// Runs `f` once per feasible-looking path of its decisions, depth first: returns each
    /// path's condition (a conjunction) and result. Paths whose condition is constant false are
    /// never produced (constant decisions do not fork).
    pub fn explore<T>(&mut self, mut f: impl FnMut(&mut Sym) -> T) -> Vec<(B, T)> {
        let mut out = Vec::new();
        self.script.clear();
        loop {
            self.cursor = 0;
            self.path.clear();
            let r = f(self);
            let lits = std::mem::take(&mut self.path);
            let cond = lits.iter().fold(B(self.mk(Node::Bool(true))), |acc, &l| self.and(acc, l));
            out.push((cond, r));
            self.script.truncate(self.cursor);
            while self.script.last() == Some(&true) {
                self.script.pop();
            }
            match self.script.last_mut() {
                Some(d) => *d = true,
                None => return out,
            }
        }
    }

    /// `c ? a : b` for terms of sort `sort`.
    fn ite(&mut self, sort: Sort, c: u32, a: u32, b: u32) -> u32 {
        if a == b {
            return a;
        }
        match self.bool_of(c) {
            Some(true) => a,
            Some(false) => b,
            None => self.mk(Node::Ite(sort, c, a, b)),
        }
    }

    /// The SMT-LIB 2 text declaring every variable, defining every node `asserts` and `keep`
    /// reach, and asserting each of `asserts`.
    pub fn smtlib(&self, asserts: &[B], keep: &[B]) -> String {
        let mut need = vec![false; self.nodes.len()];
        // Every variable is declared, read or not, so a model can be asked for each.
        let mut stack: Vec<u32> =
            asserts.iter().chain(keep).map(|b| b.0).chain(self.vars.iter().map(|v| v.0)).collect();
        while let Some(i) = stack.pop() {
            if std::mem::replace(&mut need[i as usize], true) {
                continue;
            }
            match self.nodes[i as usize] {
                Node::Not(a) => stack.push(a),
                Node::And(a, b)
                | Node::Or(a, b)
                | Node::Add(a, b)
                | Node::Sub(a, b)
                | Node::Div(a, b)
                | Node::Rem(a, b)
                | Node::Mask(a, b)
                | Node::Shr(a, b)
                | Node::Eq(a, b)
                | Node::Lt(a, b) => stack.extend([a, b]),
                Node::Ite(_, c, a, b) => stack.extend([c, a, b]),
                _ => {}
            }
        }
        let mut s = String::from("(set-logic QF_BV)\n(set-option :produce-models true)\n");
        for (i, n) in self.nodes.iter().enumerate() {
            if !need[i] {
                continue;
            }
            let _ = match n {
                Node::Var(sort, name) => writeln!(s, "(declare-fun {name} () {})", sort_name(*sort)),
                // Declared and equated rather than `define-fun`: z3 and cvc5 expand a
                // `define-fun` as a macro before bit-blasting, which costs minutes here.
                _ => writeln!(
                    s,
                    "(declare-fun t{i} () {})\n(assert (= t{i} {}))",
                    sort_name(self.sort(i as u32)),
                    self.expr(i as u32)
                ),
            };
        }
        for r in asserts {
            let _ = writeln!(s, "(assert {})", self.name(r.0));
        }
        s
    }

    /// How bit `b` is written in [`Sym::smtlib`]'s text.
    pub fn name_of(&self, b: B) -> String {
        self.name(b.0)
    }

    fn sort(&self, i: u32) -> Sort {
        match &self.nodes[i as usize] {
            Node::Bool(_) | Node::Not(_) | Node::And(..) | Node::Or(..) | Node::Eq(..) | Node::Lt(..) => {
                Sort::Bool
            }
            Node::Word(_)
            | Node::Add(..)
            | Node::Sub(..)
            | Node::Div(..)
            | Node::Rem(..)
            | Node::Mask(..)
            | Node::Shr(..) => Sort::Word,
            Node::Val(_) => Sort::Val,
            Node::Var(s, _) | Node::Ite(s, ..) => *s,
        }
    }

    /// How node `i` is referred to.
    fn name(&self, i: u32) -> String {
        match &self.nodes[i as usize] {
            Node::Bool(b) => b.to_string(),
            Node::Word(w) => format!("#x{w:08x}"),
            Node::Val(v) => format!("#x{v:016x}"),
            Node::Var(_, n) => n.clone(),
            _ => format!("t{i}"),
        }
    }

    fn expr(&self, i: u32) -> String {
        let n = |j: u32| self.name(j);
        match self.nodes[i as usize] {
            Node::Not(a) => format!("(not {})", n(a)),
            Node::And(a, b) => format!("(and {} {})", n(a), n(b)),
            Node::Or(a, b) => format!("(or {} {})", n(a), n(b)),
            Node::Add(a, b) => format!("(bvadd {} {})", n(a), n(b)),
            Node::Sub(a, b) => format!("(bvsub {} {})", n(a), n(b)),
            Node::Div(a, b) => format!("(bvudiv {} {})", n(a), n(b)),
            Node::Rem(a, b) => format!("(bvurem {} {})", n(a), n(b)),
            Node::Mask(a, b) => format!("(bvand {} {})", n(a), n(b)),
            Node::Shr(a, b) => format!("(bvlshr {} {})", n(a), n(b)),
            Node::Eq(a, b) => format!("(= {} {})", n(a), n(b)),
            Node::Lt(a, b) => format!("(bvult {} {})", n(a), n(b)),
            Node::Ite(_, c, a, b) => format!("(ite {} {} {})", n(c), n(a), n(b)),
            _ => self.name(i),
        }
    }

    /// `a` as `x + k` with a constant `k`, when it is a sum with a constant.
    fn offset(&self, a: W) -> Option<(W, u32)> {
        match self.nodes[a.0 as usize] {
            Node::Add(x, k) => self.word_of(k).map(|k| (W(x), k)),
            _ => None,
        }
    }

    /// Terms in the DAG (a size measure for reports).
    pub fn size(&self) -> usize {
        self.nodes.len()
    }
}

fn sort_name(s: Sort) -> &'static str {
    match s {
        Sort::Bool => "Bool",
        Sort::Word => "(_ BitVec 32)",
        Sort::Val => "(_ BitVec 64)",
    }
}

impl Logic for Sym {
    type Bit = B;
    type Word = W;
    type Val = V;

    fn bit(&mut self, b: bool) -> B {
        B(self.mk(Node::Bool(b)))
    }
    fn word(&mut self, w: u32) -> W {
        W(self.mk(Node::Word(w)))
    }
    fn val(&mut self, v: u64) -> V {
        V(self.mk(Node::Val(v)))
    }
    fn not(&mut self, a: B) -> B {
        match self.nodes[a.0 as usize] {
            Node::Bool(x) => self.bit(!x),
            Node::Not(x) => B(x),
            _ => B(self.mk(Node::Not(a.0))),
        }
    }
    fn and(&mut self, a: B, b: B) -> B {
        match (self.bool_of(a.0), self.bool_of(b.0)) {
            (Some(false), _) | (_, Some(false)) => self.bit(false),
            (Some(true), _) => b,
            (_, Some(true)) => a,
            _ if a == b => a,
            _ => B(self.mk(Node::And(a.0.min(b.0), a.0.max(b.0)))),
        }
    }
    fn or(&mut self, a: B, b: B) -> B {
        match (self.bool_of(a.0), self.bool_of(b.0)) {
            (Some(true), _) | (_, Some(true)) => self.bit(true),
            (Some(false), _) => b,
            (_, Some(false)) => a,
            _ if a == b => a,
            _ => B(self.mk(Node::Or(a.0.min(b.0), a.0.max(b.0)))),
        }
    }
    fn add(&mut self, a: W, b: W) -> W {
        // Canonical form `x + k`: the constant on the right, constants gathered (exact in
        // wrapping arithmetic), so that sums the design and the specification form differently
        // are one term.
        match (self.word_of(a.0), self.word_of(b.0)) {
            (Some(x), Some(y)) => self.word(x.wrapping_add(y)),
            (Some(0), _) => b,
            (_, Some(0)) => a,
            (Some(_), None) => self.add(b, a),
            (None, Some(k)) => match self.offset(a) {
                Some((x, k1)) => {
                    let k = self.word(k1.wrapping_add(k));
                    self.add(x, k)
                }
                None => W(self.mk(Node::Add(a.0, b.0))),
            },
            (None, None) => W(self.mk(Node::Add(a.0.min(b.0), a.0.max(b.0)))),
        }
    }
    fn sub(&mut self, a: W, b: W) -> W {
        match (self.word_of(a.0), self.word_of(b.0)) {
            (Some(x), Some(y)) => self.word(x.wrapping_sub(y)),
            (_, Some(k)) => {
                let neg = self.word(k.wrapping_neg());
                self.add(a, neg)
            }
            _ if a == b => self.word(0),
            _ => W(self.mk(Node::Sub(a.0, b.0))),
        }
    }
    fn div(&mut self, a: W, b: W) -> W {
        match (self.word_of(a.0), self.word_of(b.0)) {
            (Some(x), Some(y)) if y != 0 => self.word(x / y),
            (_, Some(1)) => a,
            // By a power of two: a shift, the same function, far easier for a solver.
            (_, Some(y)) if y.is_power_of_two() => {
                let k = self.word(y.trailing_zeros());
                W(self.mk(Node::Shr(a.0, k.0)))
            }
            _ => W(self.mk(Node::Div(a.0, b.0))),
        }
    }
    fn rem(&mut self, a: W, b: W) -> W {
        match (self.word_of(a.0), self.word_of(b.0)) {
            (Some(x), Some(y)) if y != 0 => self.word(x % y),
            (_, Some(1)) => self.word(0),
            (_, Some(y)) if y.is_power_of_two() => {
                let low = self.word(y - 1);
                self.mask(a, low)
            }
            _ => W(self.mk(Node::Rem(a.0, b.0))),
        }
    }
    fn mask(&mut self, a: W, b: W) -> W {
        match (self.word_of(a.0), self.word_of(b.0)) {
            (Some(x), Some(y)) => self.word(x & y),
            _ => W(self.mk(Node::Mask(a.0, b.0))),
        }
    }
    fn eq(&mut self, a: W, b: W) -> B {
        if a == b {
            return self.bit(true);
        }
        match (self.word_of(a.0), self.word_of(b.0)) {
            (Some(x), Some(y)) => self.bit(x == y),
            (Some(_), None) => self.eq(b, a),
            // x + k = c  ⇔  x = c − k (wrapping arithmetic is a group).
            (None, Some(c)) => match self.offset(a) {
                Some((x, k)) => {
                    let c = self.word(c.wrapping_sub(k));
                    self.eq(x, c)
                }
                None => B(self.mk(Node::Eq(a.0, b.0))),
            },
            (None, None) => {
                // x + k1 = y + k2  ⇔  x = y + (k2 − k1).
                let (x, k1) = self.offset(a).unwrap_or((a, 0));
                let (y, k2) = self.offset(b).unwrap_or((b, 0));
                let d = k2.wrapping_sub(k1);
                if x == y {
                    return self.bit(d == 0);
                }
                if d == 0 {
                    return B(self.mk(Node::Eq(x.0.min(y.0), x.0.max(y.0))));
                }
                let dw = self.word(d);
                let y = self.add(y, dw);
                B(self.mk(Node::Eq(x.0, y.0)))
            }
        }
    }
    fn lt(&mut self, a: W, b: W) -> B {
        if a == b {
            return self.bit(false);
        }
        match (self.word_of(a.0), self.word_of(b.0)) {
            (Some(x), Some(y)) => self.bit(x < y),
            (_, Some(0)) => self.bit(false),
            _ => B(self.mk(Node::Lt(a.0, b.0))),
        }
    }
    fn eq_val(&mut self, a: V, b: V) -> B {
        if a == b {
            return self.bit(true);
        }
        match (self.val_of(a.0), self.val_of(b.0)) {
            (Some(x), Some(y)) => self.bit(x == y),
            _ => B(self.mk(Node::Eq(a.0.min(b.0), a.0.max(b.0)))),
        }
    }
    fn mux(&mut self, c: B, a: W, b: W) -> W {
        W(self.ite(Sort::Word, c.0, a.0, b.0))
    }
    fn mux_bit(&mut self, c: B, a: B, b: B) -> B {
        match (self.bool_of(a.0), self.bool_of(b.0)) {
            (Some(true), Some(false)) => c,
            (Some(false), Some(true)) => self.not(c),
            (Some(true), _) => self.or(c, b),
            (Some(false), _) => {
                let n = self.not(c);
                self.and(n, b)
            }
            (_, Some(false)) => self.and(c, a),
            (_, Some(true)) => {
                let n = self.not(c);
                self.or(n, a)
            }
            _ => B(self.ite(Sort::Bool, c.0, a.0, b.0)),
        }
    }
    fn mux_val(&mut self, c: B, a: V, b: V) -> V {
        V(self.ite(Sort::Val, c.0, a.0, b.0))
    }
    fn same(&self, a: W, b: W) -> bool {
        a.0 == b.0
    }
    fn exact(&self) -> bool {
        false
    }
    fn concrete(&self, w: W) -> u32 {
        self.word_of(w.0).unwrap_or(0)
    }
    fn decide(&mut self, c: B) -> bool {
        if let Some(b) = self.bool_of(c.0) {
            return b;
        }
        if self.cursor == self.script.len() {
            self.script.push(false);
        }
        let d = self.script[self.cursor];
        self.cursor += 1;
        let lit = if d { c } else { self.not(c) };
        self.path.push(lit);
        d
    }
    fn maybe(&mut self, c: B) -> bool {
        self.bool_of(c.0) != Some(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_fold_and_terms_are_shared() {
        let mut s = Sym::default();
        let (a, b) = (s.word(3), s.word(4));
        let c = s.add(a, b);
        assert_eq!(s.word_of(c.0), Some(7));
        let x = s.var_word("x");
        let y1 = s.add(x, a);
        let y2 = s.add(x, a);
        assert_eq!(y1, y2, "hash-consed");
        let t = s.lt(x, x);
        assert_eq!(s.bool_of(t.0), Some(false));
    }

    #[test]
    fn explore_visits_every_path_once() {
        let mut s = Sym::default();
        let (p, q) = (s.var_bit("p"), s.var_bit("q"));
        let paths = s.explore(|s| {
            let a = s.decide(p);
            let b = if a { s.decide(q) } else { false };
            (a, b)
        });
        let outcomes: Vec<(bool, bool)> = paths.iter().map(|x| x.1).collect();
        assert_eq!(outcomes, vec![(false, false), (true, false), (true, true)]);
    }
}
