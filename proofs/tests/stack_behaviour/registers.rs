//! Register widths: a value that does not fit its register is an error.

use rtl::stack_manager::{Cmd, StackError, StackManager};

/// RB_FULL has no hardware bound; its count register is `RB_FULL_COUNT_BITS` wide, and a push
/// past what it holds is refused, not silently counted in a wider integer.
#[test]
fn a_value_that_does_not_fit_its_register_is_an_error() {
    let mut m = StackManager::new("RB_FULL".parse().unwrap(), 0).unwrap();
    let bits = m.widths().rb_count;
    for v in 0..(1u64 << bits) - 1 {
        m.apply(0, Cmd::Push(v)).unwrap();
    }
    let value = 1 << bits;
    assert_eq!(
        m.apply(0, Cmd::Push(7)),
        Err(StackError::Overflow { thread: 0, field: "rb_count", value, bits })
    );
    assert_eq!(m.rb(0).len() as u64, value - 1, "the refused push changed nothing");
    assert_eq!(m.apply(0, Cmd::Pop), Ok(Some(value - 2)));
}
