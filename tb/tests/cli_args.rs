//! One grammar: the shared argument groups (configurations, workload, hardware, scene data,
//! output format) are the same flags with the same help in every subcommand they apply to.

use clap::{Args, CommandFactory, Parser};
use tb::cli::stack_config::StackConfigArgs;
use tb::cli::{Cli, Command, HardwareArgs, OutputArgs, SceneArgs, WorkloadArgs};

/// `(long flag, help)` of every argument of a group.
type Flags = Vec<(String, String)>;

fn group<G: Args>() -> Flags {
    G::augment_args(clap::Command::new("group"))
        .get_arguments()
        .map(|a| {
            (
                a.get_long().expect("long flag").to_string(),
                a.get_help().map(|h| h.to_string()).unwrap_or_default(),
            )
        })
        .collect()
}

#[test]
fn every_subcommand_shows_the_same_shared_flags() {
    let (stack, workload, hardware, scenes, output) = (
        group::<StackConfigArgs>(),
        group::<WorkloadArgs>(),
        group::<HardwareArgs>(),
        group::<SceneArgs>(),
        group::<OutputArgs>(),
    );
    let applies: [(&str, Vec<&Flags>); 7] = [
        ("run", vec![&stack, &workload, &hardware, &scenes, &output]),
        ("sweep", vec![&stack, &workload, &hardware, &scenes, &output]),
        ("bench", vec![&stack, &workload, &hardware, &scenes, &output]),
        ("ablate", vec![&workload, &hardware, &scenes, &output]),
        ("depth", vec![&workload, &scenes, &output]),
        ("cost", vec![&stack, &hardware, &output]),
        ("check", vec![&stack, &output]),
    ];
    let mut cli = Cli::command();
    cli.build();
    for (name, groups) in applies {
        let sub = cli.find_subcommand_mut(name).expect(name);
        let help = sub.render_long_help().to_string();
        for (long, text) in groups.into_iter().flatten() {
            let arg = sub
                .get_arguments()
                .find(|a| a.get_long() == Some(long))
                .unwrap_or_else(|| panic!("sms {name} has no --{long}"));
            let shown = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
            assert_eq!(&shown, text, "sms {name} --{long}: help differs from the shared group's");
            assert!(help.contains(&format!("--{long}")), "sms {name} --help does not show --{long}");
        }
    }
}

#[test]
fn configuration_names_mean_the_same_everywhere() {
    for args in [
        &["sms", "run", "-c", "paper"][..],
        &["sms", "bench", "-c", "paper"],
        &["sms", "sweep", "-c", "paper"],
        &["sms", "sweep", "--configs", "RB_8,SMS"],
        &["sms", "cost", "--config", "paper"],
        &["sms", "check", "-c", "paper"],
    ] {
        let cli = Cli::try_parse_from(args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
        let stack = match &cli.command {
            Command::Run(a) => &a.stack,
            Command::Bench(a) => &a.stack,
            Command::Sweep(a) => &a.stack,
            Command::Cost(a) => &a.stack,
            Command::Check(a) => &a.stack,
            _ => unreachable!(),
        };
        let n = stack.resolve(&["SMS"]).expect("resolves").len();
        assert_eq!(n, if args.contains(&"paper") { 14 } else { 2 }, "{args:?}");
    }
    // bench and sweep run configurations of their own beside these: shape overrides are refused
    // by name rather than applied to some runs only.
    let cli = Cli::try_parse_from(["sms", "bench", "--warps", "4"]).unwrap();
    let Command::Bench(a) = cli.command else { unreachable!() };
    let e = a.stack.names_only("bench").unwrap_err().to_string();
    assert!(e.starts_with("--warps"), "{e}");
}

#[test]
fn check_prints_its_table_in_every_format() {
    let check = |format: &str| {
        let args = [
            "check",
            "--rb",
            "1,2",
            "--sh",
            "0",
            "--warp-sizes",
            "2",
            "--borrow-limits",
            "0",
            "--depth",
            "6",
        ];
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_sms"))
            .args(args)
            .args(["--format", format])
            .output()
            .expect("sms runs");
        // Both searches stop at depth 6 with new states still coming: bounded, not proved.
        assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let json: serde_json::Value = serde_json::from_str(&check("json")).expect("valid JSON");
    let rows = json["table"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "RB_1 and RB_2, one warp of 2 threads");
    assert_eq!(rows[0][0], "RB_1 warp 2");
    assert_eq!(rows[0][9], "depth cap 6");
    assert!(json["verdict"].as_str().unwrap().starts_with("bounded: no property violated, but 2 of 2"));
    let csv = check("csv");
    assert_eq!(csv.lines().count(), 3, "header and two rows, no verdict:\n{csv}");
    assert!(csv.starts_with("configuration,depth,states,"));
    assert!(check("markdown").contains("| RB_2 warp 2 | 6 |"));
    assert!(
        check("text").contains("bounded: no property violated, but 2 of 2 configurations stopped at a cap")
    );
}

#[test]
fn version_names_the_binary() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_sms")).arg("--version").output().unwrap();
    assert!(out.status.success());
    assert_eq!(String::from_utf8_lossy(&out.stdout), format!("sms {}\n", env!("CARGO_PKG_VERSION")));
}

#[test]
fn configuration_name_errors_say_what_is_wrong_in_the_names_written() {
    let error = |name: &str| {
        let args = StackConfigArgs {
            config: vec![name.to_owned()],
            warps: None,
            warp_size: None,
            borrow_limit: None,
            flush_limit: None,
        };
        format!("{:#}", args.resolve(&[]).expect_err(name))
    };
    let invalid = |name: &str, rest: &str| format!("--config {name}: invalid configuration: {rest}");
    for (name, rest) in [
        (
            "SMS+SK",
            "config = SMS+SK: SMS stands alone (it is RB_8+SH_8+SK+RA); to change it, write its parts out",
        ),
        (
            "sms+ra",
            "config = sms+ra: SMS stands alone (it is RB_8+SH_8+SK+RA); to change it, write its parts out",
        ),
        (
            "RB_8+XX",
            "config = RB_8+XX: unknown part 'XX': expected RB_N, RB_FULL, SH_M, SK, RA, RA_G or RT (or SMS alone)",
        ),
        ("RB_8++SK", "config = RB_8++SK: an empty part: expected RB_N or RB_FULL, then +SH_M, +SK, +RA, +RA_G or +RT"),
        ("RB_8+SH_8+ra_3", "lend_group = 3: a lending group must be a power of two from 2 to the warp size (32)"),
        ("RB_8+SH_8+RA_g", "lend_group = g: expected a number of lanes"),
        ("rb_x", "rb = x: expected a number or FULL"),
        ("RB_8+sh_y", "sh = y: expected a number"),
        ("SH_8+SK", "config = SH_8+SK: a configuration name needs an RB part: RB_N or RB_FULL"),
    ] {
        assert_eq!(error(name), invalid(name, rest));
    }
    // The parts may come in any order.
    let args = StackConfigArgs {
        config: vec!["SH_8+RB_8".into()],
        warps: None,
        warp_size: None,
        borrow_limit: None,
        flush_limit: None,
    };
    assert_eq!(args.resolve(&[]).unwrap()[0], "RB_8+SH_8".parse().unwrap());
}
