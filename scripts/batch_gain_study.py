#!/usr/bin/env python3
"""Batch round trips with per-log sensor gains (session 29).

Each batch is one static/dynamic pad (mu_s 0.42, mu_d 0.34) on the rig of
tests/batch_conflict.rs (M1 6 kg, M2 1.5 kg, K1 900 N/m, K2 600 N/m, drive
2 mm at 1.72 Hz) at six normal forces: 2.0 N never sticks, 3.0-3.6 N stick
and slip, 8 N is stuck (the pad sticks throughout from about 3.8 N). With
CONFLICT=1 the 3.6-N log is of another pad (mu_s 0.36, mu_d 0.29: 14 %
lower), which the batch should name as a conflict.
Every log draws its own sensor gains within specification (x0 +-0.5 %,
x1, x2, v2 and the normal force +-1 %, uniform), as logs recorded on
different days or with re-calibrated sensors have. The study counts, per
binary: batches with a conflict warning (all false: one pad), batches
recommending a force, and mu_s, mu_d within 3 % of the truth and covered
by their intervals.

usage: B1=old-binary B2=new-binary scripts/batch_gain_study.py DIR [N]
"""
import json
import os
import random
import subprocess
import sys

FORCES = [2.0, 3.0, 3.2, 3.4, 3.6, 8.0]
OTHER_PAD = (0.36, 0.29)
MU_S, MU_D = 0.42, 0.34
FAST = ["--bootstrap", "100", "--eta-points", "41", "--eta-fine-step", "0.005",
        "--no-ratio-variants", "--json", "--max-periods", "300", "--rho-points", "12"]


def sensors(rng):
    def ch(noise, quant, gain, offset, lowpass=None, rate=1000, buf=0.1, drop=2e-4):
        return {"rate_hz": rate, "noise": noise, "quant": quant, "gain": gain,
                "offset": offset, "lowpass_hz": lowpass, "buffer_s": buf,
                "start_offset_ns": None, "jitter_ns": 3000, "p_lost_buffer": 0.005,
                "p_dropout": drop, "dropout_burst_max": 4}
    u = lambda w: 1.0 + rng.uniform(-w, w)
    return {
        "x0": ch(1.5e-6, 5e-7, u(0.005), rng.uniform(-2e-5, 2e-5)),
        "x1": ch(3e-6, 1e-6, u(0.01), rng.uniform(-1e-4, 1e-4)),
        "x2": ch(3e-6, 1e-6, u(0.01), rng.uniform(-1e-4, 1e-4)),
        "v2": ch(1e-3, 1e-5, u(0.01), rng.uniform(-1e-4, 1e-4), lowpass=200),
        "a2": None,
        "normal_force": ch(0, 0.01, u(0.01), rng.uniform(-0.01, 0.01), rate=10, buf=0.5, drop=0),
    }


def synth(b, out, n, seed, sens_path, pad=(MU_S, MU_D)):
    cmd = [b, "synth", "--out", out, "--normal-force", str(n), "--mu-s", str(pad[0]),
           "--mu-d", str(pad[1]), "--m1-kg", "6", "--m2-kg", "1.5", "--k1-n-per-m", "900",
           "--k2-n-per-m", "600", "--amplitude-m", "0.002", "--sensors", sens_path,
           "--seed", str(seed), "--json"]
    subprocess.run(cmd, check=True, capture_output=True)


def main():
    d = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 10
    bins = {k: os.environ[k] for k in ("B1", "B2") if k in os.environ}
    conflict = os.environ.get("CONFLICT") == "1"
    rows = {k: [] for k in bins}
    for s in range(n):
        rng = random.Random(9000 + s)
        logs = []
        for i, f in enumerate(FORCES):
            sub = os.path.join(d, f"b{s:02d}")
            os.makedirs(sub, exist_ok=True)
            other = conflict and i == 4
            out = os.path.join(sub, f"n{i}{'_other' if other else ''}.mcap")
            sp = os.path.join(sub, f"n{i}.sensors.json")
            sens = sensors(rng)
            if not os.path.exists(out):
                with open(sp, "w") as fh:
                    json.dump(sens, fh)
                pad = OTHER_PAD if other else (MU_S, MU_D)
                synth(bins.get("B2") or bins["B1"], out, f, 9000 + 100 * s + i, sp, pad)
            logs.append(out)
        for k, b in bins.items():
            p = subprocess.run([b, "batch", *logs, *FAST], capture_output=True, text=True)
            try:
                v = json.loads(p.stdout)
            except json.JSONDecodeError:
                print(k, s, "no JSON", p.stderr.strip()[-300:])
                continue
            named = any(any(l.endswith("_other.mcap") for l in c["logs"][:1])
                        for c in v.get("conflicts") or [] if c["kind"] != "scatter")
            r = {
                "conflicts": len(v.get("conflicts") or []),
                "other_named_first": named,
                "rec": v.get("recommended_normal_force_n") is not None,
                "mu_s": v.get("mu_s"), "mu_s_iv": v.get("mu_s_interval"),
                "mu_d": v.get("mu_d"), "mu_d_iv": v.get("mu_d_interval"),
            }
            rows[k].append(r)
            print(k, s, json.dumps(r))
    for k, rs in rows.items():
        m = len(rs)
        within = lambda q, t: sum(abs(r[q] / t - 1) < 0.03 for r in rs if r[q])
        cov = lambda q, t: sum(r[q + "_iv"][0] <= t <= r[q + "_iv"][1] for r in rs if r[q + "_iv"])
        print(f"{k}: {m} batches; with a conflict {sum(r['conflicts'] > 0 for r in rs)}; "
              f"the other pad's log named first {sum(r['other_named_first'] for r in rs)}; "
              f"recommending {sum(r['rec'] for r in rs)}; mu_s within 3 % {within('mu_s', MU_S)}, "
              f"covered {cov('mu_s', MU_S)}; mu_d within 3 % {within('mu_d', MU_D)}, "
              f"covered {cov('mu_d', MU_D)}")


if __name__ == "__main__":
    main()
