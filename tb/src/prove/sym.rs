//! The symbolic instance of [`Logic`]: every operation builds a node of a hash-consed term DAG,
//! printed as SMT-LIB 2 over `(_ BitVec 32)` words, `Bool` bits and `(_ BitVec 64)` entry values,
//! the same widths the simulator's `u32`/`bool`/`u64` have, so the solver checks exactly the
//! arithmetic the simulator runs.
//!
//! As it builds, a `Sym` simplifies: each operator tries its [`Rule`]s in order and takes the
//! first that applies, else builds the plain SMT-LIB operator ([`Sym::plain`]). The rules fold
//! constants, keep sums in the canonical form `x + k`, turn division and remainder by powers of
//! two into shifts and masks, and drop trivial multiplexers and connectives, so that terms the
//! design and the specification form differently are one term. Both sides of every query share
//! them, so each is proved sound by a solver (`proofs/tests/rewrites.rs`). Which rules apply is a
//! [`Rewrites`] policy chosen at construction: [`Canonical`] (every rule, what `sms prove` builds
//! with) or [`Raw`] (none).
//!
//! [`Logic::decide`] forks: an execution follows a script of branch decisions and records the
//! path condition; [`Sym::explore`] enumerates every path depth first.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::rc::Rc;

use rtl::logic::Logic;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Sort {
    Bool,
    Word,
    Val,
}

/// A term: a constant, a variable or an operator over earlier terms (by id).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Node {
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

impl Node {
    /// Pushes this node's operands (term ids) onto `out`.
    pub fn push_operands(&self, out: &mut Vec<u32>) {
        match *self {
            Node::Not(a) => out.push(a),
            Node::And(a, b)
            | Node::Or(a, b)
            | Node::Add(a, b)
            | Node::Sub(a, b)
            | Node::Div(a, b)
            | Node::Rem(a, b)
            | Node::Mask(a, b)
            | Node::Shr(a, b)
            | Node::Eq(a, b)
            | Node::Lt(a, b) => out.extend([a, b]),
            Node::Ite(_, c, a, b) => out.extend([c, a, b]),
            _ => {}
        }
    }
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
pub struct Sym {
    /// The simplifications applied while building.
    rewrites: Rc<dyn Rewrites>,
    /// How many times each rule has applied, by [`Rule::ALL`] index.
    fired: Vec<u64>,
    nodes: Vec<Node>,
    memo: HashMap<Node, u32>,
    /// Branch decisions of the execution being explored, and how many it has taken.
    script: Vec<bool>,
    cursor: usize,
    /// The path condition so far: one literal per decision on a non-constant bit.
    path: Vec<B>,
    vars: Vec<(u32, Sort, String)>,
}

impl Default for Sym {
    /// A builder applying every rule ([`Canonical`]).
    fn default() -> Sym {
        Sym::with_rewrites(Rc::new(Canonical))
    }
}

impl Sym {
    /// A builder applying the simplifications `rewrites` chooses.
    pub fn with_rewrites(rewrites: Rc<dyn Rewrites>) -> Sym {
        Sym {
            rewrites,
            fired: vec![0; Rule::ALL.len()],
            nodes: Vec::new(),
            memo: HashMap::new(),
            script: Vec::new(),
            cursor: 0,
            path: Vec::new(),
            vars: Vec::new(),
        }
    }

    /// A builder applying no simplification: every operator is its plain SMT-LIB operator,
    /// constants stay constants.
    pub fn raw() -> Sym {
        Sym::with_rewrites(Rc::new(Raw))
    }

    /// `op` applied to `args` (term ids: the `.0` of [`B`], [`W`], [`V`], of the sorts
    /// [`Op::operands`] lists): the first of [`Op::rules`] the policy applies, else
    /// [`Sym::plain`].
    pub fn build(&mut self, op: Op, args: &[u32]) -> u32 {
        let rewrites = Rc::clone(&self.rewrites);
        for &rule in op.rules() {
            if let Some(t) = rewrites.apply(rule, self, args) {
                self.fired[rule as usize] += 1;
                return t;
            }
        }
        self.plain(op, args)
    }

    /// `op` applied to `args` as its plain SMT-LIB operator, whatever the policy.
    pub fn plain(&mut self, op: Op, args: &[u32]) -> u32 {
        debug_assert!(
            args.len() == op.operands().len()
                && args.iter().zip(op.operands()).all(|(&a, &s)| self.sort(a) == s),
            "{op:?} of operands of sorts {:?}",
            args.iter().map(|&a| self.sort(a)).collect::<Vec<_>>()
        );
        let x = |i: usize| args[i];
        self.mk(match op {
            Op::Not => Node::Not(x(0)),
            Op::And => Node::And(x(0), x(1)),
            Op::Or => Node::Or(x(0), x(1)),
            Op::Add => Node::Add(x(0), x(1)),
            Op::Sub => Node::Sub(x(0), x(1)),
            Op::Div => Node::Div(x(0), x(1)),
            Op::Rem => Node::Rem(x(0), x(1)),
            Op::Mask => Node::Mask(x(0), x(1)),
            Op::Eq | Op::EqVal => Node::Eq(x(0), x(1)),
            Op::Lt => Node::Lt(x(0), x(1)),
            Op::Mux => Node::Ite(Sort::Word, x(0), x(1), x(2)),
            Op::MuxBit => Node::Ite(Sort::Bool, x(0), x(1), x(2)),
            Op::MuxVal => Node::Ite(Sort::Val, x(0), x(1), x(2)),
        })
    }

    /// How many times `rule` has applied in this builder.
    pub fn fired(&self, rule: Rule) -> u64 {
        self.fired[rule as usize]
    }

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

    /// Term `i`'s value when it is a constant bit.
    pub fn bool_of(&self, i: u32) -> Option<bool> {
        match self.nodes[i as usize] {
            Node::Bool(b) => Some(b),
            _ => None,
        }
    }
    /// Term `i`'s value when it is a constant word.
    pub fn word_of(&self, i: u32) -> Option<u32> {
        match self.nodes[i as usize] {
            Node::Word(w) => Some(w),
            _ => None,
        }
    }
    /// Term `i`'s value when it is a constant entry value.
    pub fn val_of(&self, i: u32) -> Option<u64> {
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
            self.nodes[i as usize].push_operands(&mut stack);
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

    /// How term `i` is written in [`Sym::smtlib`]'s text.
    pub fn term_name(&self, i: u32) -> String {
        self.name(i)
    }

    /// Term `i`'s sort.
    pub fn sort(&self, i: u32) -> Sort {
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
    pub fn offset(&self, a: W) -> Option<(W, u32)> {
        match self.nodes[a.0 as usize] {
            Node::Add(x, k) => self.word_of(k).map(|k| (W(x), k)),
            _ => None,
        }
    }

    /// Term `i` (its operands are earlier terms' ids).
    pub fn node(&self, i: u32) -> &Node {
        &self.nodes[i as usize]
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

/// An operator of [`Logic`] as [`Sym`] builds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Op {
    Not,
    And,
    Or,
    Add,
    Sub,
    Div,
    Rem,
    Mask,
    Eq,
    Lt,
    EqVal,
    Mux,
    MuxBit,
    MuxVal,
}

impl Op {
    pub const ALL: [Op; 14] = [
        Op::Not,
        Op::And,
        Op::Or,
        Op::Add,
        Op::Sub,
        Op::Div,
        Op::Rem,
        Op::Mask,
        Op::Eq,
        Op::Lt,
        Op::EqVal,
        Op::Mux,
        Op::MuxBit,
        Op::MuxVal,
    ];

    /// The operands' sorts.
    pub fn operands(self) -> &'static [Sort] {
        use Sort::*;
        match self {
            Op::Not => &[Bool],
            Op::And | Op::Or => &[Bool, Bool],
            Op::Add | Op::Sub | Op::Div | Op::Rem | Op::Mask | Op::Eq | Op::Lt => &[Word, Word],
            Op::EqVal => &[Val, Val],
            Op::Mux => &[Bool, Word, Word],
            Op::MuxBit => &[Bool, Bool, Bool],
            Op::MuxVal => &[Bool, Val, Val],
        }
    }

    /// The result's sort.
    pub fn result(self) -> Sort {
        match self {
            Op::Add | Op::Sub | Op::Div | Op::Rem | Op::Mask | Op::Mux => Sort::Word,
            Op::MuxVal => Sort::Val,
            _ => Sort::Bool,
        }
    }

    /// The rules tried on this operator, in order; the first that applies wins.
    pub fn rules(self) -> &'static [Rule] {
        use Rule::*;
        match self {
            Op::Not => &[NotConst, NotNot],
            Op::And => &[AndFalse, AndTrue, AndSame, AndSorted],
            Op::Or => &[OrTrue, OrFalse, OrSame, OrSorted],
            Op::Add => &[AddConst, AddZero, AddConstFirst, AddMerge, AddSorted],
            Op::Sub => &[SubConst, SubConstToAdd, SubSame],
            Op::Div => &[DivConst, DivOne, DivPow2],
            Op::Rem => &[RemConst, RemOne, RemPow2],
            Op::Mask => &[MaskConst],
            Op::Eq => {
                &[EqSame, EqConst, EqConstFirst, EqOffsetConst, EqSameBase, EqCancel, EqSorted, EqMoveOffset]
            }
            Op::Lt => &[LtSame, LtConst, LtZero],
            Op::EqVal => &[EqValSame, EqValConst, EqValSorted],
            Op::Mux | Op::MuxVal => &[MuxSame, MuxConstCond],
            Op::MuxBit => &[
                MuxBitIsCond,
                MuxBitIsNotCond,
                MuxBitThenTrue,
                MuxBitThenFalse,
                MuxBitElseFalse,
                MuxBitElseTrue,
                MuxSame,
                MuxConstCond,
            ],
        }
    }
}

/// Declares [`Rule`] with its list, names and laws from one table, so no rule is left out of
/// [`Rule::ALL`].
macro_rules! rules {
    ($($(#[$doc:meta])* $rule:ident $name:literal $law:literal,)*) => {
        /// A simplification [`Sym`] applies while building a term. `k`, `c` are constants,
        /// arithmetic wraps at 32 bits, "term order" is the order the DAG created the terms in.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Rule {
            $($(#[$doc])* $rule,)*
        }

        impl Rule {
            /// Every rule, in declaration order.
            pub const ALL: &'static [Rule] = &[$(Rule::$rule,)*];

            pub fn name(self) -> &'static str {
                match self {
                    $(Rule::$rule => $name,)*
                }
            }

            /// The rule as a rewrite of its operator's operands.
            pub fn law(self) -> &'static str {
                match self {
                    $(Rule::$rule => $law,)*
                }
            }
        }
    };
}

rules! {
    NotConst "not-const" "not k → the constant",
    NotNot "not-not" "not (not a) → a",
    AndFalse "and-false" "a and false, false and b → false",
    AndTrue "and-true" "true and b → b, a and true → a",
    AndSame "and-same" "a and a → a",
    AndSorted "and-sorted" "b and a → a and b (term order)",
    OrTrue "or-true" "a or true, true or b → true",
    OrFalse "or-false" "false or b → b, a or false → a",
    OrSame "or-same" "a or a → a",
    OrSorted "or-sorted" "b or a → a or b (term order)",
    AddConst "add-const" "k1 + k2 → their sum",
    AddZero "add-zero" "0 + b → b, a + 0 → a",
    AddConstFirst "add-const-first" "k + x → x + k",
    AddMerge "add-merge" "(x + k1) + k2 → x + (k1 + k2)",
    AddSorted "add-sorted" "y + x → x + y (term order, neither constant)",
    SubConst "sub-const" "k1 − k2 → their difference",
    SubConstToAdd "sub-const-to-add" "a − k → a + (−k)",
    SubSame "sub-same" "a − a → 0",
    DivConst "div-const" "k1 / k2 → their quotient (k2 ≠ 0)",
    DivOne "div-one" "a / 1 → a",
    DivPow2 "div-pow2" "a / 2^n → a >> n",
    RemConst "rem-const" "k1 % k2 → their remainder (k2 ≠ 0)",
    RemOne "rem-one" "a % 1 → 0",
    RemPow2 "rem-pow2" "a % 2^n → a & (2^n − 1)",
    MaskConst "mask-const" "k1 & k2 → their bitwise and",
    EqSame "eq-same" "a = a → true",
    EqConst "eq-const" "k1 = k2 → the constant",
    EqConstFirst "eq-const-first" "k = x → x = k",
    EqOffsetConst "eq-offset-const" "x + k = c → x = c − k",
    EqSameBase "eq-same-base" "x + k1 = x + k2 → (k1 = k2)",
    EqCancel "eq-cancel" "x + k = y + k → x = y (term order)",
    EqSorted "eq-sorted" "y = x → x = y (term order, neither constant nor a sum with one)",
    EqMoveOffset "eq-move-offset" "x + k1 = y + k2 → x = y + (k2 − k1)",
    LtSame "lt-same" "a < a → false",
    LtConst "lt-const" "k1 < k2 → the constant",
    LtZero "lt-zero" "a < 0 → false",
    EqValSame "eq-val-same" "a = a → true (entry values)",
    EqValConst "eq-val-const" "k1 = k2 → the constant (entry values)",
    EqValSorted "eq-val-sorted" "b = a → a = b (entry values, term order)",
    MuxSame "mux-same" "c ? a : a → a",
    MuxConstCond "mux-const-cond" "true ? a : b → a, false ? a : b → b",
    MuxBitIsCond "mux-bit-is-cond" "c ? true : false → c",
    MuxBitIsNotCond "mux-bit-is-not-cond" "c ? false : true → not c",
    MuxBitThenTrue "mux-bit-then-true" "c ? true : b → c or b",
    MuxBitThenFalse "mux-bit-then-false" "c ? false : b → (not c) and b",
    MuxBitElseFalse "mux-bit-else-false" "c ? a : false → c and a",
    MuxBitElseTrue "mux-bit-else-true" "c ? a : true → (not c) or a",
}

impl Rule {
    /// What this rule makes of its operator applied to `args` (term ids, as [`Sym::build`]
    /// takes them), or None when they do not match its pattern. A rule's pattern is checked in
    /// full here, not left to the rules tried before it, so each rule is sound on its own.
    pub fn apply(self, s: &mut Sym, args: &[u32]) -> Option<u32> {
        use Rule::*;
        let a = args[0];
        let b = args.get(1).copied().unwrap_or(a);
        let (ba, bb) = (s.bool_of(a), s.bool_of(b));
        let (wa, wb) = (s.word_of(a), s.word_of(b));
        Some(match self {
            NotConst => s.bit(!ba?).0,
            NotNot => match s.nodes[a as usize] {
                Node::Not(x) => x,
                _ => return None,
            },
            AndFalse if ba == Some(false) || bb == Some(false) => s.bit(false).0,
            OrTrue if ba == Some(true) || bb == Some(true) => s.bit(true).0,
            AndTrue | OrFalse => {
                let unit = self == AndTrue;
                match (ba, bb) {
                    (Some(x), _) if x == unit => b,
                    (_, Some(x)) if x == unit => a,
                    _ => return None,
                }
            }
            AndSame | OrSame | MuxSame if args[args.len() - 2] == args[args.len() - 1] => args[1],
            AndSorted if a > b => s.plain(Op::And, &[b, a]),
            OrSorted if a > b => s.plain(Op::Or, &[b, a]),

            AddConst => s.word(wa?.wrapping_add(wb?)).0,
            AddZero if wa == Some(0) => b,
            AddZero if wb == Some(0) => a,
            AddConstFirst if wa.is_some() && wb.is_none() => s.add(W(b), W(a)).0,
            AddMerge => {
                let (k2, (x, k1)) = (wb?, s.offset(W(a))?);
                let k = s.word(k1.wrapping_add(k2));
                s.add(x, k).0
            }
            AddSorted if wa.is_none() && wb.is_none() && a > b => s.plain(Op::Add, &[b, a]),

            SubConst => s.word(wa?.wrapping_sub(wb?)).0,
            SubConstToAdd => {
                let neg = s.word(wb?.wrapping_neg());
                s.add(W(a), neg).0
            }
            SubSame if a == b => s.word(0).0,

            DivConst if wb != Some(0) => s.word(wa? / wb?).0,
            DivOne | RemOne if wb == Some(1) => match self {
                DivOne => a,
                _ => s.word(0).0,
            },
            DivPow2 if wb.is_some_and(u32::is_power_of_two) => {
                let k = s.word(wb?.trailing_zeros());
                s.mk(Node::Shr(a, k.0))
            }
            RemConst if wb != Some(0) => s.word(wa? % wb?).0,
            RemPow2 if wb.is_some_and(u32::is_power_of_two) => {
                let low = s.word(wb? - 1);
                s.mask(W(a), low).0
            }
            MaskConst => s.word(wa? & wb?).0,

            EqSame | EqValSame if a == b => s.bit(true).0,
            EqConst => s.bit(wa? == wb?).0,
            EqConstFirst if wa.is_some() && wb.is_none() => s.eq(W(b), W(a)).0,
            EqOffsetConst => {
                let (c, (x, k)) = (wb?, s.offset(W(a))?);
                let c = s.word(c.wrapping_sub(k));
                s.eq(x, c).0
            }
            EqSameBase | EqCancel | EqSorted | EqMoveOffset if wa.is_none() && wb.is_none() => {
                let (oa, ob) = (s.offset(W(a)), s.offset(W(b)));
                let (x, k1) = oa.unwrap_or((W(a), 0));
                let (y, k2) = ob.unwrap_or((W(b), 0));
                match self {
                    EqSameBase if x == y => s.bit(k1 == k2).0,
                    EqCancel if x != y && k1 == k2 && (oa.is_some() || ob.is_some()) => {
                        s.plain(Op::Eq, &[x.0.min(y.0), x.0.max(y.0)])
                    }
                    EqSorted if oa.is_none() && ob.is_none() && a > b => s.plain(Op::Eq, &[b, a]),
                    EqMoveOffset if x != y && k1 != k2 => {
                        let d = s.word(k2.wrapping_sub(k1));
                        let y = s.add(y, d);
                        s.plain(Op::Eq, &[x.0, y.0])
                    }
                    _ => return None,
                }
            }

            LtSame if a == b => s.bit(false).0,
            LtConst => s.bit(wa? < wb?).0,
            LtZero if wb == Some(0) => s.bit(false).0,

            EqValConst => {
                let (x, y) = (s.val_of(a)?, s.val_of(b)?);
                s.bit(x == y).0
            }
            EqValSorted if a > b => s.plain(Op::EqVal, &[b, a]),

            MuxConstCond => match ba? {
                true => args[1],
                false => args[2],
            },
            MuxBitIsCond | MuxBitIsNotCond | MuxBitThenTrue | MuxBitThenFalse | MuxBitElseFalse
            | MuxBitElseTrue => {
                let c = B(a);
                let (x, y) = (B(args[1]), B(args[2]));
                match (self, s.bool_of(x.0), s.bool_of(y.0)) {
                    (MuxBitIsCond, Some(true), Some(false)) => a,
                    (MuxBitIsNotCond, Some(false), Some(true)) => s.not(c).0,
                    (MuxBitThenTrue, Some(true), _) => s.or(c, y).0,
                    (MuxBitThenFalse, Some(false), _) => {
                        let n = s.not(c);
                        s.and(n, y).0
                    }
                    (MuxBitElseFalse, _, Some(false)) => s.and(c, x).0,
                    (MuxBitElseTrue, _, Some(true)) => {
                        let n = s.not(c);
                        s.or(n, x).0
                    }
                    _ => return None,
                }
            }
            _ => return None,
        })
    }
}

/// Which of the [`Rule`]s a [`Sym`] applies.
pub trait Rewrites {
    /// What `rule` makes of its operator applied to `args` in `s`, or None to try the next rule.
    fn apply(&self, rule: Rule, s: &mut Sym, args: &[u32]) -> Option<u32>;
}

/// Every rule: what `sms prove` builds with.
pub struct Canonical;

impl Rewrites for Canonical {
    fn apply(&self, rule: Rule, s: &mut Sym, args: &[u32]) -> Option<u32> {
        rule.apply(s, args)
    }
}

/// No rule: every operator is its plain SMT-LIB operator.
pub struct Raw;

impl Rewrites for Raw {
    fn apply(&self, _: Rule, _: &mut Sym, _: &[u32]) -> Option<u32> {
        None
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
        B(self.build(Op::Not, &[a.0]))
    }
    fn and(&mut self, a: B, b: B) -> B {
        B(self.build(Op::And, &[a.0, b.0]))
    }
    fn or(&mut self, a: B, b: B) -> B {
        B(self.build(Op::Or, &[a.0, b.0]))
    }
    fn add(&mut self, a: W, b: W) -> W {
        W(self.build(Op::Add, &[a.0, b.0]))
    }
    fn sub(&mut self, a: W, b: W) -> W {
        W(self.build(Op::Sub, &[a.0, b.0]))
    }
    fn div(&mut self, a: W, b: W) -> W {
        W(self.build(Op::Div, &[a.0, b.0]))
    }
    fn rem(&mut self, a: W, b: W) -> W {
        W(self.build(Op::Rem, &[a.0, b.0]))
    }
    fn mask(&mut self, a: W, b: W) -> W {
        W(self.build(Op::Mask, &[a.0, b.0]))
    }
    fn eq(&mut self, a: W, b: W) -> B {
        B(self.build(Op::Eq, &[a.0, b.0]))
    }
    fn lt(&mut self, a: W, b: W) -> B {
        B(self.build(Op::Lt, &[a.0, b.0]))
    }
    fn eq_val(&mut self, a: V, b: V) -> B {
        B(self.build(Op::EqVal, &[a.0, b.0]))
    }
    fn mux(&mut self, c: B, a: W, b: W) -> W {
        W(self.build(Op::Mux, &[c.0, a.0, b.0]))
    }
    fn mux_bit(&mut self, c: B, a: B, b: B) -> B {
        B(self.build(Op::MuxBit, &[c.0, a.0, b.0]))
    }
    fn mux_val(&mut self, c: B, a: V, b: V) -> V {
        V(self.build(Op::MuxVal, &[c.0, a.0, b.0]))
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
    fn the_raw_builder_keeps_every_operator_and_counts_no_rule() {
        let mut s = Sym::raw();
        let (a, b) = (s.word(3), s.word(4));
        let c = s.add(a, b);
        assert_eq!(s.word_of(c.0), None, "no folding");
        assert_eq!(s.expr(c.0), format!("(bvadd {} {})", s.name(a.0), s.name(b.0)));
        let x = s.var_word("x");
        let d = s.div(x, b);
        assert_eq!(s.expr(d.0), format!("(bvudiv x {})", s.name(b.0)), "no shift");
        let t = s.bit(true);
        let p = s.var_bit("p");
        let m = s.mux_bit(t, p, p);
        assert_eq!(s.expr(m.0), "(ite true p p)");
        assert!(Rule::ALL.iter().all(|&r| s.fired(r) == 0));

        let mut s = Sym::default();
        let (a, b) = (s.word(3), s.word(4));
        let x = s.var_word("x");
        let xa = s.add(x, a);
        let y = s.add(xa, b);
        assert_eq!(s.offset(y), Some((x, 7)));
        assert_eq!((s.fired(Rule::AddMerge), s.fired(Rule::AddConst)), (1, 0));
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
