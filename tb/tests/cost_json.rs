//! `sms cost --json`: parses, round-trips through serde_json, and carries the totals the text
//! report shows.

use std::process::Command;

fn sms(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_sms")).args(args).output().expect("sms runs");
    assert!(out.status.success(), "sms {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8")
}

/// The number at the end of the text line starting with `label`.
fn text_value(text: &str, label: &str) -> u64 {
    let line =
        text.lines().find(|l| l.trim_start().starts_with(label)).unwrap_or_else(|| panic!("no {label}"));
    line.split_whitespace().last().unwrap().parse().unwrap()
}

#[test]
fn cost_json_round_trips_and_has_the_texts_totals() {
    let json = sms(&["cost", "-c", "paper", "--baselines", "--json"]);
    let value: serde_json::Value = serde_json::from_str(&json).expect("valid JSON");
    let again: serde_json::Value = serde_json::from_str(&serde_json::to_string(&value).unwrap()).unwrap();
    assert_eq!(value, again);
    let reports = value.as_array().expect("an array of reports");
    assert!(reports.len() >= 14, "{}", reports.len());
    for r in reports {
        let config = r["config"].as_str().expect("config");
        let text = sms(&["cost", "-c", config]);
        let totals = &r["totals"];
        // The text's bits/SM column, summed, is the JSON's total.
        let fields = r["fields"].as_array().unwrap();
        let summed: u64 =
            fields.iter().map(|f| f["bits"].as_u64().unwrap() * f["copies_per_sm"].as_u64().unwrap()).sum();
        assert_eq!(totals["bits_per_sm"].as_u64(), Some(summed), "{config}");
        for f in fields {
            let bits_per_sm = f["bits"].as_u64().unwrap() * f["copies_per_sm"].as_u64().unwrap();
            let name = f["name"].as_str().unwrap();
            let line = text.lines().find(|l| l.split_whitespace().next() == Some(name)).expect(name);
            assert!(line.split_whitespace().any(|w| w == bits_per_sm.to_string()), "{config} {name}: {line}");
        }
        // The control registers: their own rows and total, outside `bits_per_sm`.
        let control = r["control"].as_array().unwrap();
        assert!(!control.is_empty(), "{config}");
        let mut control_bits = 0;
        for f in control {
            assert_eq!(f["origin"].as_str(), Some("control"), "{config}");
            let bits_per_sm = f["bits"].as_u64().unwrap() * f["copies_per_sm"].as_u64().unwrap();
            control_bits += bits_per_sm;
            let name = f["name"].as_str().unwrap();
            let line = text.lines().find(|l| l.split_whitespace().next() == Some(name)).expect(name);
            assert!(line.split_whitespace().any(|w| w == bits_per_sm.to_string()), "{config} {name}: {line}");
        }
        assert_eq!(totals["control_bits_per_sm"].as_u64(), Some(control_bits), "{config}");
        assert_eq!(
            totals["added_bytes_per_sm"].as_u64(),
            Some(text_value(&text, "RTL: total added over the short stack")),
            "{config}"
        );
        assert_eq!(r["sms"].as_u64(), Some(8), "{config}");
    }
    // --format json is the same output; --sms is the hardware's flag.
    assert_eq!(sms(&["cost", "-c", "paper", "--baselines", "--format", "json"]), json);
    let four: serde_json::Value = serde_json::from_str(&sms(&["cost", "--sms", "4", "--json"])).unwrap();
    assert_eq!(four[0]["sms"].as_u64(), Some(4));
    assert_eq!(
        four[0]["totals"]["bits_per_gpu"].as_u64(),
        Some(4 * four[0]["totals"]["bits_per_sm"].as_u64().unwrap())
    );
}
