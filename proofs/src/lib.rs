//! Reference unbounded stack, scoreboard and stack-consistency properties.
