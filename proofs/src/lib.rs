//! Tests of the stack-consistency properties (in `tests/`). The reference stack, scoreboard,
//! properties and drivers they exercise live in the product, `tb::run::verify`, which the
//! functional level and `sms check` run on: the product never depends on this crate.
