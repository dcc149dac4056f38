//! The JSON form of a batch comparison (the `batch` contract's keys plus
//! details; hand-built: its keys are computed per coefficient).

use super::{Batch, MuFit, Worst};
use crate::io::json::num;
use serde_json::{json, Value};

fn interval(i: (f64, f64)) -> Value {
    crate::io::json::interval(Some(i))
}

fn worst_json(w: &Worst) -> Value {
    json!({
        "rho_s": num(w.rho_s),
        "rho_d": num(w.rho_d),
        "worst_amplitude1": num(w.amplitude1),
        "eta": num(w.eta),
        "branch": w.branch.as_str(),
        "unsettled": w.unsettled,
        "coexisting_points": w.coexisting,
    })
}

fn mu_keys(out: &mut serde_json::Map<String, Value>, name: &str, m: &MuFit) {
    out.insert(name.into(), num(m.mu));
    out.insert(format!("{name}_interval"), interval(m.interval));
    out.insert(format!("{name}_stat_interval"), interval(m.stat_interval));
    out.insert(format!("{name}_systematic_rel"), num(m.systematic_rel));
    out.insert(format!("{name}_birge"), num(m.birge));
    out.insert(
        format!("{name}_chi2_per_dof"),
        m.chi2_per_dof.map_or(Value::Null, num),
    );
    out.insert(format!("{name}_points"), json!(m.points));
    out.insert(format!("{name}_censored"), json!(m.censored));
    let (slope, a, hw) = m.free.unwrap_or((f64::NAN, f64::NAN, f64::NAN));
    out.insert(format!("{name}_free_slope"), num(slope));
    out.insert(format!("{name}_intercept_n"), num(a));
    out.insert(
        format!("{name}_intercept_interval_n"),
        interval((a - hw, a + hw)),
    );
}

impl Batch {
    /// The batch keys of the JSON output (everything but `fits`).
    pub fn to_json_map(&self) -> serde_json::Map<String, Value> {
        batch_json(self)
    }
}

fn batch_json(b: &Batch) -> serde_json::Map<String, Value> {
    let mut o = serde_json::Map::new();
    mu_keys(&mut o, "mu_s", &b.mu_s);
    mu_keys(&mut o, "mu_d", &b.mu_d);
    let ins = |o: &mut serde_json::Map<String, Value>, k: &str, v: Value| {
        o.insert(k.into(), v);
    };
    // Both ways: without the conflicting logs (the keys above) and with
    // every log.
    let mut all = serde_json::Map::new();
    mu_keys(&mut all, "mu_s", &b.mu_s_all);
    mu_keys(&mut all, "mu_d", &b.mu_d_all);
    ins(&mut o, "all_logs", Value::Object(all));
    let set_aside = |pick: fn(&super::BatchLog) -> bool| -> Value {
        json!(b
            .logs
            .iter()
            .filter(|l| pick(l))
            .map(|l| l.log.display().to_string())
            .collect::<Vec<_>>())
    };
    ins(&mut o, "mu_s_set_aside", set_aside(|l| l.set_aside.0));
    ins(&mut o, "mu_d_set_aside", set_aside(|l| l.set_aside.1));
    let conflicts: Vec<Value> = b
        .conflicts
        .iter()
        .map(|c| {
            json!({
                "logs": c.logs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
                "quantity": c.quantity,
                "kind": c.kind,
                "what": c.what,
                "size_sigma": num(c.size_sigma),
                "size_rel": num(c.size_rel),
                "set_aside": c.set_aside,
            })
        })
        .collect();
    ins(&mut o, "conflicts", json!(conflicts));
    ins(&mut o, "mu_ratio", num(b.ratio));
    ins(&mut o, "mu_ratio_interval", interval(b.ratio_interval));
    match &b.recommendation {
        Some(r) => {
            ins(&mut o, "recommended_normal_force_n", num(r.normal_force_n));
            ins(
                &mut o,
                "recommended_normal_force_interval_n",
                interval(r.interval_n),
            );
            ins(&mut o, "recommended_rho_s", num(r.rho_s));
            ins(&mut o, "recommended_rho_d", num(r.rho_d));
            ins(&mut o, "recommended_rho_s_box", interval(r.rho_s_box));
            ins(&mut o, "worst_amplitude1", num(r.worst.amplitude1));
            ins(
                &mut o,
                "worst_amplitude1_interval",
                interval(r.worst_interval),
            );
            ins(&mut o, "worst_amplitude1_robust", num(r.worst_interval.1));
            ins(&mut o, "worst_eta", num(r.worst.eta));
            ins(&mut o, "worst_branch", json!(r.worst.branch.as_str()));
            ins(&mut o, "worst_coexisting_points", json!(r.worst.coexisting));
            ins(&mut o, "worst_coexisting_eta", num(r.worst.coexisting_eta));
        }
        None => {
            for k in [
                "recommended_normal_force_n",
                "recommended_normal_force_interval_n",
                "recommended_rho_s",
                "recommended_rho_d",
                "recommended_rho_s_box",
                "worst_amplitude1",
                "worst_amplitude1_interval",
                "worst_amplitude1_robust",
                "worst_eta",
                "worst_branch",
                "worst_coexisting_points",
                "worst_coexisting_eta",
            ] {
                ins(&mut o, k, Value::Null);
            }
        }
    }
    if let Some(reason) = &b.recommendation_reason {
        ins(&mut o, "recommendation_reason", json!(reason));
    }
    match &b.cliff {
        Some(c) => {
            ins(&mut o, "cliff_rho_s", num(c.rho_s));
            ins(&mut o, "cliff_rho_s_bracket", interval(c.bracket));
            ins(&mut o, "cliff_normal_force_n", num(c.normal_force_n));
            ins(&mut o, "cliff_threshold", num(c.threshold));
            ins(
                &mut o,
                "cliff_worst_amplitude1",
                num(c.worst_below.amplitude1),
            );
            ins(&mut o, "cliff_eta", num(c.worst_below.eta));
            ins(&mut o, "margin_to_cliff", num(c.margin_rel));
            ins(&mut o, "margin_to_cliff_rho_s", num(c.margin_rho_s));
            ins(&mut o, "margin_to_cliff_n", num(c.margin_n));
        }
        None => {
            for k in [
                "cliff_rho_s",
                "cliff_rho_s_bracket",
                "cliff_normal_force_n",
                "cliff_threshold",
                "cliff_worst_amplitude1",
                "cliff_eta",
                "margin_to_cliff",
                "margin_to_cliff_rho_s",
                "margin_to_cliff_n",
            ] {
                ins(&mut o, k, Value::Null);
            }
        }
    }
    let settings: Vec<Value> = b
        .logs
        .iter()
        .map(|l| {
            json!({
                "log": l.log.display().to_string(),
                "normal_force_n": num(l.normal_force_n),
                "static": l.static_obs.as_str(),
                "mu_s_log": l.mu_s.0.map_or(Value::Null, num),
                "mu_s_log_bounds": match (l.mu_s.1, l.mu_s.2) {
                    (None, None) => Value::Null,
                    (a, b) => json!([a.map_or(Value::Null, num), b.map_or(Value::Null, num)]),
                },
                "mu_d_log": l.mu_d.map_or(Value::Null, num),
                "rho_s_log": l.rho_s.map_or(Value::Null, num),
                "rho_s_model": num(l.model_rho_s),
                "worst_amplitude1": l.worst.map_or(Value::Null, |w| num(w.amplitude1)),
                "worst_eta": l.worst.map_or(Value::Null, |w| num(w.eta)),
                "worst_branch": l.worst.map_or(Value::Null, |w| json!(w.branch.as_str())),
                "consistent": l.consistent,
                "set_aside_mu_s": l.set_aside.0,
                "set_aside_mu_d": l.set_aside.1,
                "estimate_disagreement_rs_sigma": num(l.estimate_disagreement.0),
                "estimate_disagreement_rd_sigma": num(l.estimate_disagreement.1),
                "drive_amplitude_m": num(l.drive_amplitude_m),
            })
        })
        .collect();
    ins(&mut o, "settings", json!(settings));
    let curve: Vec<Value> = b
        .curve
        .iter()
        .map(|c| {
            let mut v = worst_json(&c.worst);
            v["normal_force_n"] = num(c.normal_force_n);
            v["robust_worst_amplitude1"] = c.robust.map_or(Value::Null, num);
            v
        })
        .collect();
    ins(&mut o, "curve", json!(curve));
    ins(&mut o, "drive_amplitude_m", num(b.drive_amplitude_m));
    ins(
        &mut o,
        "drive_amplitude_source",
        json!(b.drive_amplitude_source),
    );
    ins(
        &mut o,
        "measured_drive_amplitude_m",
        num(b.measured_drive_amplitude_m),
    );
    ins(&mut o, "force_scale_n", num(b.force_scale_n));
    ins(&mut o, "m", num(b.absorber.m));
    ins(&mut o, "k", num(b.absorber.k));
    ins(&mut o, "damping", num(b.absorber.damping));
    ins(&mut o, "eta_range", interval(b.eta_range));
    ins(&mut o, "eta_points", json!(b.eta_points));
    ins(&mut o, "setting_tolerance", num(b.setting_tolerance));
    ins(&mut o, "evaluations", json!(b.evaluations));
    ins(&mut o, "warnings", json!(b.warnings));
    o
}
