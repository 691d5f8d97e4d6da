//! One registry of hardware parameters: each key of a hardware description is declared once, with
//! its section, name, field, type, default, bound and help, and everything else is generated from
//! that declaration: the struct and its `Default`, the single-key bounds of `validate`, and the
//! `KEYS` table that `tb` reads descriptions through, prints `--hw`'s help from and tests presets
//! against for completeness.
//!
//! Bounds that relate two keys (a line of whole sectors, a cache of whole sets) stay in the
//! structs' own `validate`, after the registry's per-key bounds.

use crate::config::ConfigError;

/// One value a key takes, as a description spells it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Value {
    Uint(u32),
    Bool(bool),
    Name(&'static str),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Uint(v) => write!(f, "{v}"),
            Value::Bool(b) => write!(f, "{b}"),
            Value::Name(n) => write!(f, "\"{n}\""),
        }
    }
}

/// What a key's values are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A whole number.
    Uint,
    /// `true` or `false`.
    Bool,
    /// One of these names.
    Choice(&'static [&'static str]),
    /// Ways of a cache: a whole number, 0 meaning fully associative.
    Ways,
}

/// A field type a key can set: its [`Kind`] and the conversions to and from a [`Value`]. Every
/// `named_enum!` is one, of kind [`Kind::Choice`].
pub trait Param: Copy {
    const KIND: Kind;
    fn value(self) -> Value;
    /// `None` when `v` is not of this type's kind or names no value of it.
    fn from_value(v: Value) -> Option<Self>;
}

impl Param for u32 {
    const KIND: Kind = Kind::Uint;
    fn value(self) -> Value {
        Value::Uint(self)
    }
    fn from_value(v: Value) -> Option<u32> {
        match v {
            Value::Uint(u) => Some(u),
            _ => None,
        }
    }
}

impl Param for bool {
    const KIND: Kind = Kind::Bool;
    fn value(self) -> Value {
        Value::Bool(self)
    }
    fn from_value(v: Value) -> Option<bool> {
        match v {
            Value::Bool(b) => Some(b),
            _ => None,
        }
    }
}

/// The range a whole-number key must lie in, and what the error says when it does not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bound {
    pub least: u32,
    pub most: u32,
    /// The error's reason, `{least}` and `{most}` replaced by the range's ends; empty: "must be at
    /// least `least`" (or "at most `most`").
    pub why: &'static str,
}

impl Bound {
    /// Any value of the type.
    pub const ANY: Bound = Bound { least: 0, most: u32::MAX, why: "" };

    pub const fn at_least(least: u32) -> Bound {
        Bound { least, most: u32::MAX, why: "" }
    }

    /// The same range, the error giving `why`.
    pub const fn because(self, why: &'static str) -> Bound {
        Bound { why, ..self }
    }

    fn check(&self, parameter: &'static str, v: u32) -> Result<(), ConfigError> {
        if (self.least..=self.most).contains(&v) {
            return Ok(());
        }
        let reason = match (self.why, self.least, self.most) {
            ("", least, u32::MAX) => format!("must be at least {least}"),
            ("", 0, most) => format!("must be at most {most}"),
            ("", least, most) => format!("must be {least} to {most}"),
            (why, least, most) => {
                why.replace("{least}", &least.to_string()).replace("{most}", &most.to_string())
            }
        };
        Err(ConfigError { parameter, value: v.to_string(), reason })
    }
}

/// One key of a hardware description, read and written on a `T`.
pub struct Key<T> {
    /// The description's table: `rt`, `stack` or `mem`.
    pub section: &'static str,
    /// The key within the table.
    pub key: &'static str,
    /// The struct field it sets (named by validation errors).
    pub field: &'static str,
    /// The field's documentation.
    pub help: &'static str,
    pub kind: Kind,
    /// Whole-number keys' range (ignored for the other kinds).
    pub bound: Bound,
    /// A run option rather than hardware: presets need not set it.
    pub run_option: bool,
    pub get: fn(&T) -> Value,
    /// Sets the field; `false` (nothing changed) when the value is not of the key's kind.
    pub set: fn(&mut T, Value) -> bool,
}

impl<T> Key<T> {
    /// `section.key`, as errors and help name it.
    pub fn path(&self) -> String {
        format!("{}.{}", self.section, self.key)
    }

    /// The first line of the help: one sentence for a key list.
    pub fn summary(&self) -> &'static str {
        self.help.lines().next().unwrap_or("").trim()
    }
}

/// Checks every key's bound on `p`; the error names the first field out of its range.
pub fn check_bounds<T>(keys: &[Key<T>], p: &T) -> Result<(), ConfigError> {
    for k in keys {
        if let Value::Uint(v) = (k.get)(p) {
            if k.kind == Kind::Uint {
                k.bound.check(k.field, v)?;
            }
        }
    }
    Ok(())
}

/// One [`Key`] of `$t`'s field `$field` (of type `$ty`).
#[macro_export]
macro_rules! param_key {
    ($t:ty, $section:literal, $key:literal, $field:ident: $ty:ty, $help:expr, $bound:expr, $run:expr) => {
        $crate::params::Key::<$t> {
            section: $section,
            key: $key,
            field: stringify!($field),
            help: $help,
            kind: <$ty as $crate::params::Param>::KIND,
            bound: $bound,
            run_option: $run,
            get: |p: &$t| $crate::params::Param::value(p.$field),
            set: |p: &mut $t, v: $crate::params::Value| match <$ty as $crate::params::Param>::from_value(v) {
                Some(x) => {
                    p.$field = x;
                    true
                }
                None => false,
            },
        }
    };
}

/// A parameter struct declared as its registry: every field with its doc, `["section" "key"]`
/// (optionally `, bound` for a whole number, and `; run` for a run option), type and default.
/// Generates the struct, `Default` and `KEYS`.
macro_rules! params {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                [$section:literal $key:literal $(, $bound:expr)? $(; $run:ident)?]
                pub $field:ident: $ty:ty = $default:expr,
            )+
        }
    ) => {
        $(#[$meta])*
        pub struct $name {
            $(
                $(#[doc = $doc])*
                pub $field: $ty,
            )+
        }

        impl Default for $name {
            fn default() -> Self {
                $name { $($field: $default,)+ }
            }
        }

        impl $name {
            /// Every key of this struct, in field order ([`crate::params`]).
            pub const KEYS: &'static [$crate::params::Key<$name>] = &[$(
                $crate::param_key!(
                    $name, $section, $key, $field: $ty,
                    concat!($($doc, "\n"),*),
                    params!(@bound $($bound)?),
                    params!(@run $($run)?)
                ),
            )+];
        }
    };
    (@bound) => { $crate::params::Bound::ANY };
    (@bound $b:expr) => { $b };
    (@run) => { false };
    (@run run) => { true };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::MemParams;
    use crate::rt_unit::{RtParams, StackParams};

    #[test]
    fn every_key_reads_back_what_it_sets_and_refuses_other_kinds() {
        fn round_trip<T: Default>(keys: &[Key<T>]) {
            for k in keys {
                let mut p = T::default();
                let other = match k.kind {
                    Kind::Uint | Kind::Ways => Value::Uint(7),
                    Kind::Bool => Value::Bool(!matches!((k.get)(&p), Value::Bool(true))),
                    Kind::Choice(names) => Value::Name(names[names.len() - 1]),
                };
                assert!((k.set)(&mut p, other), "{}", k.path());
                assert_eq!((k.get)(&p), other, "{}", k.path());
                let wrong = match k.kind {
                    Kind::Bool => Value::Uint(1),
                    _ => Value::Bool(true),
                };
                assert!(!(k.set)(&mut p, wrong), "{} took {wrong}", k.path());
                assert_eq!((k.get)(&p), other, "{}: a refused value changed the field", k.path());
                assert!(!k.summary().is_empty(), "{} has no help", k.path());
            }
        }
        round_trip(RtParams::KEYS);
        round_trip(StackParams::KEYS);
        round_trip(MemParams::KEYS);
        assert!(!(MemParams::KEYS.iter().find(|k| k.key == "l1d_write").unwrap().set)(
            &mut MemParams::default(),
            Value::Name("back")
        ));
    }

    #[test]
    fn keys_are_unique_and_name_their_fields() {
        let mut seen = std::collections::HashSet::new();
        let paths = RtParams::KEYS
            .iter()
            .map(|k| (k.path(), k.field))
            .chain(StackParams::KEYS.iter().map(|k| (k.path(), k.field)))
            .chain(MemParams::KEYS.iter().map(|k| (k.path(), k.field)));
        for (path, field) in paths {
            assert!(seen.insert(path.clone()), "{path} declared twice");
            assert!(!field.is_empty());
        }
        assert_eq!(MemParams::KEYS.iter().find(|k| k.key == "l1d_ways").unwrap().field, "l1d_assoc");
    }

    #[test]
    fn bounds_name_the_field_and_say_why() {
        let p = RtParams { triangle: 0, ..RtParams::default() };
        let e = check_bounds(RtParams::KEYS, &p).unwrap_err();
        assert_eq!((e.parameter, e.value.as_str()), ("triangle", "0"));
        assert_eq!(e.reason, "operation latency must be at least 1 cycle");
        let m = MemParams { dram_queue: 0, ..MemParams::default() };
        assert_eq!(check_bounds(MemParams::KEYS, &m).unwrap_err().reason, "must be at least 1");
        let s = StackParams { sh_latency: 1, ..StackParams::default() };
        let e = check_bounds(StackParams::KEYS, &s).unwrap_err();
        assert_eq!(
            (e.parameter, e.reason.as_str()),
            ("sh_latency", "an SH access takes at least 2 cycles (issue, then the bank)")
        );
        assert!(check_bounds(RtParams::KEYS, &RtParams::default()).is_ok());
        assert!(check_bounds(StackParams::KEYS, &StackParams::default()).is_ok());
        assert!(check_bounds(MemParams::KEYS, &MemParams::default()).is_ok());
    }
}
