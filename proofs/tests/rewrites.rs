//! The simplifications `Sym` applies while building terms (`tb::prove::sym::Rule`) are shared by
//! the design's and the specification's sides of every `sms prove` query, so a wrong one would
//! prove a falsehood on both. Here each rule is proved sound on its own by z3 and boolector, on
//! every operand shape of a pool that it matches; random expression trees show the rules
//! compose soundly and that the built terms compute what the simulator's `Int` instance
//! computes; planted wrong rules are caught and named; and whole one-step queries built with no
//! rule at all give the same verdicts.
//!
//! The solvers are Debian's `z3` and `boolector`; a test fails saying which to install when one
//! is missing.

use std::collections::HashMap;
use std::rc::Rc;
use std::time::Duration;

use rtl::config::{Config, RbSize, Realloc, ShPolicy};
use rtl::logic::{Int, Logic};
use rtl::stack_manager::mutants::Mutated;
use rtl::stack_manager::policy::{Design, Steps};
use rtl::stack_manager::Mutant;
use tb::prove::obligations;
use tb::prove::query::one_step_in;
use tb::prove::solver::{check, Solver, Verdict};
use tb::prove::sym::{Canonical, Op, Raw, Rewrites, Rule, Sort, Sym, B, W};

const LIMIT: Duration = Duration::from_secs(120);

fn solvers() -> Vec<Solver> {
    Solver::defaults_installed().unwrap_or_else(|e| panic!("{e}"))
}

/// Applies only `rule`, as `policy` does it (so one rule is checked at a time, and a
/// policy's version of it is the one checked).
struct Only {
    rule: Rule,
    policy: Rc<dyn Rewrites>,
}

impl Rewrites for Only {
    fn apply(&self, rule: Rule, s: &mut Sym, args: &[u32]) -> Option<u32> {
        if rule == self.rule {
            self.policy.apply(rule, s, args)
        } else {
            None
        }
    }
}

/// A rule's version: what it makes of its operator's operands, if it applies.
type Version = fn(&mut Sym, &[u32]) -> Option<u32>;

/// The canonical rules with `rule` replaced by a wrong version: the planted bugs.
struct Planted {
    rule: Rule,
    wrong: Version,
}

impl Rewrites for Planted {
    fn apply(&self, rule: Rule, s: &mut Sym, args: &[u32]) -> Option<u32> {
        if rule == self.rule {
            (self.wrong)(s, args)
        } else {
            rule.apply(s, args)
        }
    }
}

/// (x + k1) + k2 → x + (k1 | k2): the constants merged without carries.
fn merge_without_carry(s: &mut Sym, args: &[u32]) -> Option<u32> {
    let k2 = s.word_of(args[1])?;
    let (x, k1) = s.offset(W(args[0]))?;
    let k = s.word(k1 | k2);
    Some(s.add(x, k).0)
}

/// a % 2^n → a & 2^n: the mask one too high.
fn mask_with_the_power(s: &mut Sym, args: &[u32]) -> Option<u32> {
    let d = s.word_of(args[1]).filter(|d| d.is_power_of_two())?;
    let m = s.word(d);
    Some(s.mask(W(args[0]), m).0)
}

/// a − k → a + k: the sign lost when a difference becomes a sum.
fn sub_as_add(s: &mut Sym, args: &[u32]) -> Option<u32> {
    s.word_of(args[1])?;
    Some(s.add(W(args[0]), W(args[1])).0)
}

/// x + k1 = y + k2 → x = y + (k1 − k2): the offset moved with the wrong sign.
fn move_offset_backwards(s: &mut Sym, args: &[u32]) -> Option<u32> {
    let (a, b) = (W(args[0]), W(args[1]));
    if s.word_of(a.0).is_some() || s.word_of(b.0).is_some() {
        return None;
    }
    let (x, k1) = s.offset(a).unwrap_or((a, 0));
    let (y, k2) = s.offset(b).unwrap_or((b, 0));
    if x == y || k1 == k2 {
        return None;
    }
    let d = s.word(k1.wrapping_sub(k2));
    let y = s.add(y, d);
    Some(s.plain(Op::Eq, &[x.0, y.0]))
}

/// c ? false : b → c and b: the condition's negation forgotten.
fn mux_without_not(s: &mut Sym, args: &[u32]) -> Option<u32> {
    (s.bool_of(args[1]) == Some(false)).then(|| s.and(B(args[0]), B(args[2])).0)
}

/// The planted wrong rules: (the rule replaced, its wrong version).
fn planted() -> Vec<(Rule, Version)> {
    vec![
        (Rule::AddMerge, merge_without_carry),
        (Rule::RemPow2, mask_with_the_power),
        (Rule::SubConstToAdd, sub_as_add),
        (Rule::EqMoveOffset, move_offset_backwards),
        (Rule::MuxBitThenFalse, mux_without_not),
    ]
}

/// The operands every rule is tried on, per sort, built plain: fresh variables and the
/// constant shapes the rules match (0, 1, powers of two, all ones, sums with a constant on
/// either side, a negation), each with a label for reports.
fn pool(s: &mut Sym) -> HashMap<Sort, Vec<(u32, String)>> {
    let (p, q) = (s.var_bit("p"), s.var_bit("q"));
    let (t, f) = (s.bit(true), s.bit(false));
    let not_p = s.plain(Op::Not, &[p.0]);
    let bits = vec![
        (p.0, "p".to_string()),
        (q.0, "q".into()),
        (t.0, "true".into()),
        (f.0, "false".into()),
        (not_p, "(not p)".into()),
    ];
    let (x, y) = (s.var_word("x"), s.var_word("y"));
    let mut words = vec![(x.0, "x".to_string()), (y.0, "y".into())];
    for k in [0, 1, 3, 4, 0x8000_0000, 0xffff_ffff] {
        words.push((s.word(k).0, format!("{k:#x}")));
    }
    for (v, k, label) in [(x, 1, "x + 1"), (x, 0xffff_ffff, "x + 0xffffffff"), (y, 1, "y + 1")] {
        let k = s.word(k);
        words.push((s.plain(Op::Add, &[v.0, k.0]), label.into()));
    }
    let three = s.word(3);
    words.push((s.plain(Op::Add, &[three.0, x.0]), "0x3 + x".into()));
    let (u, v) = (s.var_val("u"), s.var_val("v"));
    let mut vals = vec![(u.0, "u".to_string()), (v.0, "v".into())];
    for k in [0, u64::MAX] {
        vals.push((s.val(k).0, format!("{k:#x}")));
    }
    HashMap::from([(Sort::Bool, bits), (Sort::Word, words), (Sort::Val, vals)])
}

/// Every tuple of `pool` operands of the sorts `op` takes.
fn operand_tuples(pool: &HashMap<Sort, Vec<(u32, String)>>, op: Op) -> Vec<Vec<&(u32, String)>> {
    op.operands().iter().fold(vec![Vec::new()], |tuples, sort| {
        tuples
            .iter()
            .flat_map(|t| pool[sort].iter().map(move |x| t.iter().copied().chain([x]).collect()))
            .collect()
    })
}

/// `a = b` for terms of `sort`, built plain (the checks' own terms must not go through the
/// rules they check).
fn same(s: &mut Sym, sort: Sort, a: u32, b: u32) -> u32 {
    match sort {
        Sort::Word => s.plain(Op::Eq, &[a, b]),
        Sort::Val => s.plain(Op::EqVal, &[a, b]),
        Sort::Bool => {
            let nb = s.plain(Op::Not, &[b]);
            s.plain(Op::MuxBit, &[a, b, nb])
        }
    }
}

/// The SMT-LIB query asking for an assignment where some of `parts` (named bits) is false,
/// built plain, with an `agree_k` variable per part; and the variables to ask for.
fn differ_query(s: &mut Sym, parts: &[(String, u32)]) -> (String, Vec<String>) {
    let all = parts.iter().skip(1).fold(parts[0].1, |acc, p| s.plain(Op::And, &[acc, p.1]));
    let differ = s.plain(Op::Not, &[all]);
    let keep: Vec<B> = parts.iter().map(|p| B(p.1)).collect();
    let mut text = s.smtlib(&[B(differ)], &keep);
    for (k, b) in keep.iter().enumerate() {
        text += &format!("(declare-fun agree_{k} () Bool)\n(assert (= agree_{k} {}))\n", s.name_of(*b));
    }
    let mut vars: Vec<String> = s.vars().map(|v| v.0.to_string()).collect();
    vars.extend((0..parts.len()).map(|k| format!("agree_{k}")));
    (text, vars)
}

/// Asks each of `solvers` for an assignment where some part differs: Ok when none exists,
/// else the parts that differ and the assignment.
fn prove_parts(s: &mut Sym, parts: &[(String, u32)], solvers: &[Solver]) -> Result<(), String> {
    let (text, vars) = differ_query(s, parts);
    for &sv in solvers {
        match check(sv, &text, &vars, LIMIT).unwrap().0 {
            Verdict::Proved => {}
            Verdict::Counterexample(vals) => {
                let failed: Vec<&str> = (0..parts.len())
                    .filter(|k| vals.iter().any(|(n, v)| *n == format!("agree_{k}") && *v == 0))
                    .map(|k| parts[k].0.as_str())
                    .collect();
                let more = failed.len().saturating_sub(3);
                let failed = failed[..failed.len() - more].join(", ")
                    + &if more > 0 { format!(" and {more} more") } else { String::new() };
                let at: Vec<String> = vals
                    .iter()
                    .filter(|v| !v.0.starts_with("agree_"))
                    .map(|(n, v)| format!("{n} = {v:#x}"))
                    .collect();
                return Err(format!("{failed} differ ({}: {})", sv.name(), at.join(", ")));
            }
            Verdict::Unknown(why) => return Err(format!("{}: {why}", sv.name())),
        }
    }
    Ok(())
}

/// `policy`'s version of `rule`, alone, proved sound by `solvers`: on every pool operand tuple
/// of every operator that tries the rule where it applies, the term it builds equals the plain
/// operator's. Returns how many tuples it applied to; an operator on which it never applies
/// is an error (the pool lacks a shape the rule matches).
fn check_rule(policy: &Rc<dyn Rewrites>, rule: Rule, solvers: &[Solver]) -> Result<usize, String> {
    let mut s = Sym::with_rewrites(Rc::new(Only { rule, policy: Rc::clone(policy) }));
    let pool = pool(&mut s);
    let mut parts = Vec::new();
    for op in Op::ALL.into_iter().filter(|op| op.rules().contains(&rule)) {
        let before = parts.len();
        for args in operand_tuples(&pool, op) {
            let ids: Vec<u32> = args.iter().map(|a| a.0).collect();
            let fired = s.fired(rule);
            let t = s.build(op, &ids);
            if s.fired(rule) > fired {
                let plain = s.plain(op, &ids);
                let labels: Vec<&str> = args.iter().map(|a| a.1.as_str()).collect();
                parts.push((format!("{op:?}({})", labels.join(", ")), same(&mut s, op.result(), t, plain)));
            }
        }
        if parts.len() == before {
            return Err(format!("never applies to {op:?} on the operand pool: add a shape it matches"));
        }
    }
    prove_parts(&mut s, &parts, solvers)?;
    Ok(parts.len())
}

/// Every rule of `policy` checked alone: the rules found unsound, with why.
fn unsound_rules(policy: Rc<dyn Rewrites>, solvers: &[Solver]) -> Vec<(Rule, String)> {
    Rule::ALL.iter().filter_map(|&r| check_rule(&policy, r, solvers).err().map(|e| (r, e))).collect()
}

#[test]
fn every_rule_is_tried_by_an_operator() {
    for r in Rule::ALL {
        assert!(Op::ALL.iter().any(|op| op.rules().contains(r)), "rule {} is never tried", r.name());
    }
}

#[test]
fn every_rule_is_sound_on_every_shape_it_applies_to() {
    let sv = solvers();
    let policy: Rc<dyn Rewrites> = Rc::new(Canonical);
    for &r in Rule::ALL {
        match check_rule(&policy, r, &sv) {
            Ok(n) => println!("{:22} {:44} proved on {n} operand tuples", r.name(), r.law()),
            Err(e) => panic!("rule {} ({}): {e}", r.name(), r.law()),
        }
    }
}

#[test]
fn a_planted_wrong_rule_is_named_and_no_other() {
    let sv = solvers();
    for (rule, wrong) in planted() {
        let unsound = unsound_rules(Rc::new(Planted { rule, wrong }), &sv[..1]);
        for (r, why) in &unsound {
            println!("planted {}: {} reported: {why}", rule.name(), r.name());
        }
        assert_eq!(
            unsound.iter().map(|u| u.0).collect::<Vec<_>>(),
            vec![rule],
            "planted a wrong {}: the rules reported unsound",
            rule.name()
        );
    }
}

#[test]
fn a_rule_that_matches_no_shape_of_the_pool_fails_the_check() {
    // A rule's version that never applies stands for a rule whose pattern the pool lacks.
    let never = Planted { rule: Rule::AddMerge, wrong: |_, _| None };
    let e = check_rule(&(Rc::new(never) as Rc<dyn Rewrites>), Rule::AddMerge, &solvers()).unwrap_err();
    assert!(e.contains("never applies to Add"), "{e}");
}

/// An expression tree over a few variables of each sort.
#[derive(Clone, Debug)]
enum Expr {
    Var(Sort, usize),
    Const(Sort, u64),
    Apply(Op, Vec<Expr>),
}

/// A deterministic xorshift stream.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

const VARS: usize = 3;

/// A random constant of `sort`, mostly from the values the rules single out.
fn constant(rng: &mut Rng, sort: Sort) -> u64 {
    let words = [0, 1, 2, 3, 4, 7, 8, 0x7fff_ffff, 0x8000_0000, 0xffff_fffe, 0xffff_ffff];
    match sort {
        Sort::Bool => rng.next() & 1,
        Sort::Word if rng.below(4) > 0 => words[rng.below(words.len())],
        Sort::Word => rng.next() & 0xffff_ffff,
        Sort::Val => [0, 1, u64::MAX, rng.next()][rng.below(4)],
    }
}

/// A random tree of `sort` at most `depth` deep. A divisor is a non-zero constant or, with
/// `symbolic_divisors`, `(e & 7) + 1`, so the simulator's operators never divide by zero.
fn tree(rng: &mut Rng, sort: Sort, depth: u32, symbolic_divisors: bool) -> Expr {
    if depth == 0 || rng.below(4) == 0 {
        return match rng.below(2) {
            0 => Expr::Var(sort, rng.below(VARS)),
            _ => Expr::Const(sort, constant(rng, sort)),
        };
    }
    let ops: Vec<Op> = Op::ALL.into_iter().filter(|op| op.result() == sort).collect();
    let op = ops[rng.below(ops.len())];
    let mut args: Vec<Expr> =
        op.operands().iter().map(|&s| tree(rng, s, depth - 1, symbolic_divisors)).collect();
    if matches!(op, Op::Div | Op::Rem) {
        args[1] = match symbolic_divisors && rng.below(2) == 0 {
            false => Expr::Const(Sort::Word, constant(rng, Sort::Word).max(1)),
            true => {
                let low = Expr::Apply(Op::Mask, vec![args[1].clone(), Expr::Const(Sort::Word, 7)]);
                Expr::Apply(Op::Add, vec![low, Expr::Const(Sort::Word, 1)])
            }
        };
    }
    Expr::Apply(op, args)
}

fn var_name(sort: Sort, i: usize) -> String {
    let p = match sort {
        Sort::Bool => "b",
        Sort::Word => "w",
        Sort::Val => "v",
    };
    format!("{p}{i}")
}

/// `e` built in `s`, each operator through `apply` (the policy's [`Sym::build`] or
/// [`Sym::plain`]).
fn build(s: &mut Sym, e: &Expr, apply: fn(&mut Sym, Op, &[u32]) -> u32) -> u32 {
    match e {
        Expr::Var(sort, i) => {
            let n = var_name(*sort, *i);
            match sort {
                Sort::Bool => s.var_bit(&n).0,
                Sort::Word => s.var_word(&n).0,
                Sort::Val => s.var_val(&n).0,
            }
        }
        Expr::Const(Sort::Bool, k) => s.bit(*k != 0).0,
        Expr::Const(Sort::Word, k) => s.word(*k as u32).0,
        Expr::Const(Sort::Val, k) => s.val(*k).0,
        Expr::Apply(op, args) => {
            let ids: Vec<u32> = args.iter().map(|a| build(s, a, apply)).collect();
            apply(s, *op, &ids)
        }
    }
}

/// `e`'s value on the simulator's instance ([`Int`]), the variables given by `env`.
fn eval_int(e: &Expr, env: &dyn Fn(Sort, usize) -> u64) -> u64 {
    let l = &mut Int;
    match e {
        Expr::Var(sort, i) => env(*sort, *i),
        Expr::Const(_, k) => *k,
        Expr::Apply(op, args) => {
            let a: Vec<u64> = args.iter().map(|x| eval_int(x, env)).collect();
            let (w, b) = (|i: usize| a[i] as u32, |i: usize| a[i] != 0);
            match op {
                Op::Not => l.not(b(0)) as u64,
                Op::And => l.and(b(0), b(1)) as u64,
                Op::Or => l.or(b(0), b(1)) as u64,
                Op::Add => l.add(w(0), w(1)) as u64,
                Op::Sub => l.sub(w(0), w(1)) as u64,
                Op::Div => l.div(w(0), w(1)) as u64,
                Op::Rem => l.rem(w(0), w(1)) as u64,
                Op::Mask => l.mask(w(0), w(1)) as u64,
                Op::Eq => l.eq(w(0), w(1)) as u64,
                Op::Lt => l.lt(w(0), w(1)) as u64,
                Op::EqVal => l.eq_val(a[0], a[1]) as u64,
                Op::Mux => l.mux(b(0), w(1), w(2)) as u64,
                Op::MuxBit => l.mux_bit(b(0), b(1), b(2)) as u64,
                Op::MuxVal => l.mux_val(b(0), a[1], a[2]),
            }
        }
    }
}

/// `n` random trees of every sort, `depth` deep, from `seed`.
fn forest(seed: u64, n: usize, depth: u32, symbolic_divisors: bool) -> Vec<Expr> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|k| tree(&mut rng, [Sort::Bool, Sort::Word, Sort::Val][k % 3], depth, symbolic_divisors))
        .collect()
}

/// Each of `trees` built under `policy` and plain in one DAG, proved equal for every value of
/// the variables by `solvers`, 50 trees a query.
fn trees_agree(policy: Rc<dyn Rewrites>, trees: &[Expr], solvers: &[Solver]) -> Result<(), String> {
    for chunk in trees.chunks(50) {
        let mut s = Sym::with_rewrites(Rc::clone(&policy));
        let mut parts = Vec::new();
        for e in chunk {
            let t = build(&mut s, e, Sym::build);
            let p = build(&mut s, e, Sym::plain);
            let sort = s.sort(t);
            parts.push((format!("{e:x?}"), same(&mut s, sort, t, p)));
        }
        prove_parts(&mut s, &parts, solvers)?;
    }
    Ok(())
}

/// Each of `trees` built under `policy`, evaluated by z3 with the variables fixed at random
/// values: the value the simulator's instance computes, for `rounds` assignments.
fn trees_compute_what_the_simulator_does(
    policy: Rc<dyn Rewrites>,
    trees: &[Expr],
    seed: u64,
    rounds: usize,
) -> Result<(), String> {
    let mut rng = Rng(seed);
    for _ in 0..rounds {
        let vals: HashMap<(Sort, usize), u64> = [Sort::Bool, Sort::Word, Sort::Val]
            .into_iter()
            .flat_map(|s| (0..VARS).map(move |i| (s, i)))
            .map(|(s, i)| ((s, i), constant(&mut rng, s)))
            .collect();
        let mut s = Sym::with_rewrites(Rc::clone(&policy));
        let roots: Vec<u32> = trees.iter().map(|e| build(&mut s, e, Sym::build)).collect();
        // The variables fixed, built plain.
        let fixed: Vec<B> = vals
            .iter()
            .map(|(&(sort, i), &k)| {
                let x = build(&mut s, &Expr::Var(sort, i), Sym::plain);
                let k = build(&mut s, &Expr::Const(sort, k), Sym::plain);
                B(same(&mut s, sort, x, k))
            })
            .collect();
        // Kept so their definitions are written (`keep` takes any term's id).
        let keep: Vec<B> = roots.iter().map(|&r| B(r)).collect();
        let text = s.smtlib(&fixed, &keep);
        let names: Vec<String> = roots.iter().map(|&r| s.term_name(r)).collect();
        let Verdict::Counterexample(got) = check(Solver::Z3, &text, &names, LIMIT).unwrap().0 else {
            return Err("z3 found no model of the fixed variables".into());
        };
        let got: HashMap<String, u64> = got.into_iter().collect();
        let env = |sort: Sort, i: usize| vals[&(sort, i)];
        for (e, name) in trees.iter().zip(&names) {
            let want = eval_int(e, &env);
            if got.get(name) != Some(&want) {
                return Err(format!("{e:x?} is {want:#x} on Int, {:x?} as built ({vals:x?})", got.get(name)));
            }
        }
    }
    Ok(())
}

#[test]
fn random_trees_built_with_the_rules_equal_their_plain_terms() {
    let sv = solvers();
    let trees = forest(0x5eed, 400, 4, false);
    trees_agree(Rc::new(Canonical), &trees, &sv).unwrap_or_else(|e| panic!("{e}"));
    // The same trees catch the planted wrong rules.
    for (rule, wrong) in planted() {
        let r = trees_agree(Rc::new(Planted { rule, wrong }), &trees, &sv[..1]);
        println!("planted {}: {r:?}", rule.name());
        assert!(r.is_err(), "a wrong {} survived the random trees", rule.name());
    }
}

#[test]
fn random_trees_compute_what_the_simulator_computes() {
    solvers();
    let trees = forest(0xc0ffee, 400, 4, true);
    trees_compute_what_the_simulator_does(Rc::new(Canonical), &trees, 7, 8).unwrap_or_else(|e| panic!("{e}"));
    trees_compute_what_the_simulator_does(Rc::new(Raw), &trees, 7, 8)
        .unwrap_or_else(|e| panic!("plain: {e}"));
    for (rule, wrong) in planted() {
        let r = trees_compute_what_the_simulator_does(Rc::new(Planted { rule, wrong }), &trees, 7, 8);
        println!("planted {}: {r:?}", rule.name());
        assert!(r.is_err(), "a wrong {} survived", rule.name());
    }
}

fn cfg(rb: u32, m: u32, ra: Option<(u32, u32)>, warp_size: u32, warps: u32) -> Config {
    let c = Config {
        rb: RbSize::Entries(rb),
        sh_entries: m,
        skew: false,
        policy: ShPolicy::from(ra.map(|(borrow_limit, flush_limit)| Realloc { borrow_limit, flush_limit })),
        warp_size,
        warps,
        ..Config::default()
    };
    c.validate().expect("a valid test configuration");
    c
}

/// The one-step query `name` at `c` for `steps`, built with the rules and with none: each
/// solver's verdict on both, and the solve times (with rules, without).
fn both_builds<P: Steps>(
    c: &Config,
    steps: &P,
    name: &str,
    sv: &[Solver],
) -> Vec<(Verdict, Verdict, f64, f64)> {
    let ob = obligations(c).into_iter().find(|o| o.name == name).expect("the obligation exists");
    let canonical = one_step_in(Sym::default(), c, steps, ob.base, &ob.cmds);
    let raw = one_step_in(Sym::raw(), c, steps, ob.base, &ob.cmds);
    sv.iter()
        .map(|&s| {
            let (a, ta) = check(s, &canonical.text, &canonical.vars, LIMIT).unwrap();
            let (b, tb) = check(s, &raw.text, &raw.vars, LIMIT).unwrap();
            println!(
                "{name:16} {:14} {:10} with the rules {:6.2} s ({} terms), without {:6.2} s ({} terms): {:.2}x",
                c.name(),
                s.name(),
                ta.as_secs_f64(),
                canonical.terms,
                tb.as_secs_f64(),
                raw.terms,
                tb.as_secs_f64() / ta.as_secs_f64()
            );
            (a, b, ta.as_secs_f64(), tb.as_secs_f64())
        })
        .collect()
}

#[test]
fn one_step_queries_built_without_the_rules_give_the_same_verdicts() {
    let sv = solvers();
    let c = cfg(1, 1, Some((2, 1)), 4, 2);
    for name in ["one-step push", "one-step pop", "one-step finish"] {
        for (a, b, ..) in both_builds(&c, &Design, name, &sv) {
            assert_eq!((a, b), (Verdict::Proved, Verdict::Proved), "the design's {name}");
        }
    }
    // A planted bug in the design is a counterexample either way.
    for (a, b, ..) in both_builds(&c, &Mutated(Mutant::LinkWithThreadId), "one-step push", &sv) {
        assert!(
            matches!((&a, &b), (Verdict::Counterexample(_), Verdict::Counterexample(_))),
            "link-with-thread-id: {a:?} with the rules, {b:?} without"
        );
    }
}
