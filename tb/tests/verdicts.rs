//! What `sms check` and `sms prove` claim and how they exit: a proof only for what was searched
//! to its end (exit 0), a search stopped at a cap reported as bounded with the cap and depth
//! named (exit 2), a name that selects nothing an error listing the names (exit 1).

mod common;
use common::{sms_status, Ran};

/// The one-configuration grid `RB_1 warp 2` with `more` flags.
fn grid(more: &[&str]) -> Ran {
    let base = ["check", "--rb", "1", "--sh", "0", "--warp-sizes", "2", "--borrow-limits", "0"];
    let args: Vec<&str> = base.iter().chain(more).copied().collect();
    sms_status(&args)
}

#[test]
fn a_grid_search_stopped_by_its_depth_is_bounded_not_proved() {
    let r = grid(&["--depth", "6"]);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(r.stdout.contains("depth cap 6"), "{}", r.stdout);
    assert!(!r.stdout.contains("all properties hold"), "{}", r.stdout);
    let verdict = "bounded: no property violated, but 1 of 1 configurations stopped at a cap before their \
                   fixpoint, so nothing is proved for them: RB_1 warp 2 (depth cap 6)";
    assert!(r.stdout.contains(verdict), "{}", r.stdout);
    assert!(r.stderr.lines().last().is_some_and(|l| l.starts_with(verdict)), "{}", r.stderr);
}

#[test]
fn a_grid_search_under_a_cap_reaches_its_fixpoint_and_is_proved() {
    let r = grid(&["--cap", "2"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.stdout.contains("fixpoint at depth"), "{}", r.stdout);
    assert!(
        r.stdout.contains("all properties hold on 1 configurations, each searched to its fixpoint"),
        "{}",
        r.stdout
    );
}

#[test]
fn a_search_stopped_by_the_state_limit_is_bounded_and_a_zero_limit_is_an_error() {
    let r = grid(&["--max-states", "1", "--cap", "2"]);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(r.stdout.contains("state cap 1 at depth 1"), "{}", r.stdout);
    assert!(r.stdout.contains("bounded: no property violated"), "{}", r.stdout);
    let zero = grid(&["--max-states", "0"]);
    assert_eq!(zero.code, Some(1));
    assert_eq!(zero.stdout, "", "nothing searched, nothing reported");
    assert_eq!(
        zero.stderr,
        "error: --max-states 0: a search holds at least its initial state; give 1 or more\n"
    );
}

#[test]
fn a_full_case_stopped_before_its_fixpoint_is_bounded() {
    let only = ["check", "--full", "--only", "RB_1 warp 2"];
    let proved = sms_status(&only);
    assert_eq!(proved.code, Some(0), "{}", proved.stderr);
    assert!(proved.stdout.contains("every property proved on 1 configurations to the fixpoint"));
    let capped: Vec<&str> = only.iter().chain(&["--max-states", "10", "--format", "json"]).copied().collect();
    let r = sms_status(&capped);
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    let json: serde_json::Value = serde_json::from_str(&r.stdout).expect("JSON");
    let verdict = json["verdict"].as_str().expect("a verdict");
    assert!(
        verdict.starts_with("bounded: no property violated, but 1 of 1 cases stopped at the state cap"),
        "{verdict}"
    );
    assert!(verdict.contains("RB_1 warp 2 (state cap 10 at depth"), "{verdict}");
    assert_eq!(json["table"]["rows"][0][9], "state cap");
}

#[test]
fn only_that_selects_nothing_is_an_error_listing_the_names() {
    let r = sms_status(&["check", "--full", "--only", "zzzz"]);
    assert_eq!(r.code, Some(1));
    assert_eq!(r.stderr.lines().count(), 1, "{}", r.stderr);
    assert!(r
        .stderr
        .starts_with("error: --only \"zzzz\": no case of the full set matches; the cases: RB_1 warp 2; "));
    assert!(r.stderr.contains("; RB_1+SH_32+SK+RA warp 32 borrow 1 flush 1 lanes "), "{}", r.stderr);
    // Checked before any solver is looked for: the names come from the configuration.
    let r = sms_status(&["prove", "--only", "zzzz"]);
    assert_eq!(r.code, Some(1));
    assert_eq!(r.stdout, "");
    assert_eq!(r.stderr.lines().count(), 1, "{}", r.stderr);
    assert!(
        r.stderr.starts_with(
            "error: --only \"zzzz\": no property's name contains it; the properties: one-step push; "
        ),
        "{}",
        r.stderr
    );
    assert!(r.stderr.contains("; conservation through pop"), "{}", r.stderr);
}

#[test]
fn check_help_states_the_exit_statuses() {
    let r = sms_status(&["check", "--help"]);
    assert_eq!(r.code, Some(0));
    assert!(
        r.stdout.contains("Exit status: 0 when every configuration's search reached its fixpoint"),
        "{}",
        r.stdout
    );
    assert!(
        r.stdout.contains("2 when no property is violated but some search stopped at a cap"),
        "{}",
        r.stdout
    );
}
