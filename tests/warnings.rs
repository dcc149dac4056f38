//! `warning_codes` beside every `warnings` of the JSON (interface.md): a
//! list of the same length, each a documented snake_case code. The bundled
//! logs that warn give the expected codes (matched as codes, not text).

mod common;

use common::{bin, data, json_of};
use serde_json::Value;
use stickslip::warning::CODES;

/// Checks every object of `v` that has `warnings`: `warning_codes` beside
/// it, as long, each code one of [`CODES`]. Returns the codes found (with
/// their object's path) and how many `warnings` lists were seen.
fn check(v: &Value, path: &str, found: &mut Vec<(String, String)>) -> usize {
    let mut lists = 0;
    match v {
        Value::Object(m) => {
            if let Some(w) = m.get("warnings") {
                let w = w.as_array().unwrap_or_else(|| panic!("{path}: warnings"));
                let c = m
                    .get("warning_codes")
                    .and_then(Value::as_array)
                    .unwrap_or_else(|| panic!("{path}: warnings without warning_codes"));
                assert_eq!(w.len(), c.len(), "{path}: {w:?} vs {c:?}");
                for (code, text) in c.iter().zip(w) {
                    let code = code.as_str().expect("a code is a string");
                    assert!(CODES.contains(&code), "{path}: unknown code {code}");
                    assert!(text.is_string(), "{path}: {text}");
                    found.push((path.to_string(), code.to_string()));
                }
                lists += 1;
            } else {
                assert!(
                    !m.contains_key("warning_codes"),
                    "{path}: warning_codes without warnings"
                );
            }
            for (k, x) in m {
                lists += check(x, &format!("{path}/{k}"), found);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                lists += check(x, &format!("{path}[{i}]"), found);
            }
        }
        _ => {}
    }
    lists
}

fn has(found: &[(String, String)], path: &str, code: &str) -> bool {
    found.iter().any(|(p, c)| p == path && c == code)
}

#[test]
fn ingest_gives_a_code_per_warning() {
    // law_decreasing.mcap has no accelerometer channel.
    let v = json_of(bin().args([
        "ingest",
        data("law_decreasing.mcap").to_str().unwrap(),
        "--json",
    ]));
    let mut found = Vec::new();
    assert_eq!(check(&v, "", &mut found), 1);
    assert!(has(&found, "", "channel_absent"), "{found:?}");
}

#[test]
fn fit_records_give_a_code_per_warning() {
    // char_N1.2: M2 never sticks; law_stribeck: no simple law fits; both
    // have samples without accelerometer data, and law_stribeck's drive
    // amplitude is off the nominal.
    let v = json_of(bin().args([
        "fit",
        "--json",
        data("char_N1.2.mcap").to_str().unwrap(),
        data("law_stribeck.mcap").to_str().unwrap(),
    ]));
    let mut found = Vec::new();
    assert_eq!(check(&v, "", &mut found), 2);
    assert!(has(&found, "/fits[0]", "never_sticks"), "{found:?}");
    assert!(has(&found, "/fits[0]", "acceleration_filled"), "{found:?}");
    assert!(has(&found, "/fits[1]", "no_simple_law"), "{found:?}");
    assert!(has(&found, "/fits[1]", "drive_amplitude"), "{found:?}");
    assert!(!has(&found, "/fits[1]", "never_sticks"), "{found:?}");
}

#[test]
fn characteristic_gives_a_code_per_warning() {
    let v = json_of(bin().args([
        "characteristic",
        data("char_N1.2.mcap").to_str().unwrap(),
        "--json",
    ]));
    let mut found = Vec::new();
    assert_eq!(check(&v, "", &mut found), 1);
    assert!(has(&found, "", "acceleration_filled"), "{found:?}");
}

/// The checker itself: a `warnings` list without its codes, or with one
/// code too few, or an unknown code, is caught.
#[test]
fn the_check_catches_missing_or_short_codes() {
    let run = |v: Value| std::panic::catch_unwind(|| check(&v, "", &mut Vec::new())).is_err();
    let ok = serde_json::json!({"warnings": ["a"], "warning_codes": ["clipped"]});
    assert!(!run(ok));
    assert!(run(serde_json::json!({"x": {"warnings": ["a"]}})));
    assert!(run(
        serde_json::json!({"warnings": ["a", "b"], "warning_codes": ["clipped"]})
    ));
    assert!(run(
        serde_json::json!({"warnings": ["a"], "warning_codes": ["No Such"]})
    ));
}

#[test]
fn validate_gives_a_code_per_warning() {
    // The stepped sweep at 7.2 N has a drive amplitude off the nominal.
    let v = json_of(bin().args([
        "validate",
        "--json",
        "--characteristic",
        data("char_N7.2.mcap").to_str().unwrap(),
        "--sweep",
        data("sweep_stepped_N7.2.mcap").to_str().unwrap(),
    ]));
    let mut found = Vec::new();
    assert_eq!(check(&v, "", &mut found), 2, "the validation and its fit");
    assert!(has(&found, "", "drive_amplitude"), "{found:?}");
    assert!(has(&found, "/fit", "acceleration_filled"), "{found:?}");
}

#[test]
fn batch_gives_a_code_per_warning() {
    // char_N4.mcap given twice counts once, with a warning. The bundled
    // pad's logs agree within their intervals: no conflict (their sensors'
    // gains differ from log to log, by up to 1.6 % in the normal force,
    // which the equation-error estimates' scatter once flagged as one).
    let logs = [
        "char_N1.2.mcap",
        "char_N2.2.mcap",
        "char_N4.mcap",
        "char_N7.2.mcap",
        "char_N30.mcap",
        "char_N4.mcap",
    ];
    let mut cmd = bin();
    cmd.arg("batch").arg("--json");
    for l in logs {
        cmd.arg(data(l));
    }
    let v = json_of(&mut cmd);
    let mut found = Vec::new();
    // The batch and one fit record per log given.
    assert_eq!(check(&v, "", &mut found), 1 + logs.len());
    assert!(!has(&found, "", "conflict"), "{found:?}");
    assert!(has(&found, "", "duplicate"), "{found:?}");
    assert!(has(&found, "/fits[0]", "never_sticks"), "{found:?}");
}
