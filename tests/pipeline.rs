//! `stickslip run` on a plan with a log that cannot be decoded (a missing
//! one is refused before any work, `tests/misuse.rs`): its read error is
//! reported once, every other log keeps its own fit (the fits are matched
//! to the logs that were read, in plan order), the exit status is 1, the
//! last stderr line says no output was written.

mod common;

use common::{bin, data, without_seconds};
use serde_json::Value;

#[test]
fn an_unread_log_does_not_shift_the_fits_of_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.toml");
    let missing = dir.path().join("corrupt.mcap");
    std::fs::copy(data("broken/not_mcap.mcap"), &missing).unwrap();
    let good = data("char_N4.mcap");
    std::fs::write(
        &plan,
        format!(
            "fit = [{:?}, {:?}]\n",
            missing.display().to_string(),
            good.display().to_string()
        ),
    )
    .unwrap();
    let out = bin().arg("run").arg(&plan).arg("--json").output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 2, "{stderr}");
    assert!(errors[0].contains("corrupt.mcap"), "{stderr}");
    assert_eq!(stderr.lines().last(), Some(errors[1]), "{stderr}");
    assert!(errors[1].contains("no output written"), "{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let fits = v["fits"].as_array().unwrap();
    assert_eq!(fits.len(), 2);
    assert!(
        fits[0]["error"].as_str().unwrap().contains("not read"),
        "{}",
        fits[0]
    );
    assert!(fits[1].get("error").is_none(), "{}", fits[1]);
    assert!(fits[1]["log"].as_str().unwrap().ends_with("char_N4.mcap"));
    assert_eq!(fits[1]["law"], "static-dynamic");
}

/// A sweep beyond the bytes `run` keeps from its reading to its
/// validation is read again there: the same validation, bit for bit, as
/// with the sweep kept (the library's `pipeline::run` with
/// `hold_sweeps` false against the default).
#[test]
fn a_sweep_read_again_validates_as_one_kept() {
    use stickslip::pipeline::{self, Options, Plan};
    let dir = tempfile::tempdir().unwrap();
    let plan_path = dir.path().join("plan.toml");
    std::fs::write(
        &plan_path,
        format!(
            "[[validate]]\ncharacteristic = {:?}\nsweep = {:?}\n",
            data("char_N4.mcap").display().to_string(),
            data("sweep_continuous_N4.mcap").display().to_string()
        ),
    )
    .unwrap();
    let plan = Plan::read(&plan_path).unwrap();
    let json_of = |hold_sweeps: bool| {
        let opts = Options {
            samples: 40,
            figures: false,
            hold_sweeps,
            ..Options::default()
        };
        let report = pipeline::run(&plan, &opts, &()).unwrap();
        assert!(report.errors.is_empty(), "{:?}", report.errors);
        assert!(report
            .logs
            .values()
            .all(|l| l.as_ref().unwrap().figure.is_none()));
        let mut v = report.to_json(&plan, &plan_path);
        without_seconds(&mut v);
        v
    };
    let kept = json_of(true);
    let read_again = json_of(false);
    assert!(kept["validations"][0].get("error").is_none(), "{kept}");
    assert_eq!(kept, read_again);
}
