"""Compliant contacts on four rigs: coverage of κ, Rs and Rd where the pad
deflects before it slides (issue 34). Logs from `synth` with a contact
spring whose pre-sliding Rs/kt is drawn between 15 and 150 µm, static-dynamic
pads, sensors drawn as in adequacy_study.py (realistic specifications, not
the estimator's noise model).

    python3 scripts/compliant_study.py DIR [N]        # write the logs
    python3 scripts/compliant_study.py DIR N --fit    # fit them, print the table

B=path/to/stickslip picks the binary (default target/release/stickslip);
OUT_JSON=path keeps the per-log results."""
import json, math, os, random, subprocess, sys, time

sys.path.insert(0, os.path.dirname(__file__))
from adequacy_study import RIGS, draw  # noqa: E402

B = os.environ.get('B', 'target/release/stickslip')


def logs(out, n, family=('static-dynamic', 1), prefix='c', seeds=(3434, 500)):
    """Writes n logs of `family` (its name and index in the draw's family
    cycle) behind a contact spring; `seeds`: the draw's and synth's."""
    os.makedirs(out, exist_ok=True)
    rng = random.Random(seeds[0])
    rows = []
    for i in range(n):
        # The family's pads (index 4·family + rig): the draw's family cycle.
        args, s, fam = draw(rng, 4 * family[1] + (i % len(RIGS)))
        assert fam == family[0], fam
        rig = RIGS[i % len(RIGS)]
        rs = float(args[args.index('--rs-n') + 1])
        rd = float(args[args.index('--rd-n') + 1])
        pre = rng.uniform(15e-6, 150e-6)
        kt = rs / pre
        args += ['--contact-stiffness-n-per-m', str(kt)]
        name = f'{out}/{prefix}{i:03d}.mcap'
        sj = f'{out}/{prefix}{i:03d}.sensors.json'
        if not os.path.exists(name):
            json.dump(s, open(sj, 'w'))
            subprocess.run([B, 'synth', '--out', name, '--sensors', sj, '--seed', str(seeds[1] + i),
                            '--duration-s', '20'] + args, check=True, capture_output=True)
        rows.append(dict(log=name, rs=rs, rd=rd, kappa=kt / rig['k2'], pre_um=pre * 1e6))
    json.dump(rows, open(f'{out}/rows.json', 'w'), indent=1)
    return rows


def inside(iv, v):
    return iv is not None and iv[0] <= v <= iv[1]


def fit(rows):
    res = []
    for r in rows:
        t0 = time.time()
        p = subprocess.run([B, 'fit', r['log'], '--json'], capture_output=True, text=True)
        dt = time.time() - t0
        f = json.loads(p.stdout)['fits'][0]
        k = f.get('contact_stiffness')
        res.append(dict(r, secs=round(dt, 2), law=f['law'], k=k, k_iv=f['contact_stiffness_interval'],
                        k_lb=f['contact_stiffness_lower_bound'], rs_fit=f['r_s_n'], rs_iv=f['r_s_interval_n'],
                        rd_fit=f['r_d_n'], rd_iv=f['r_d_interval_n'], adequate=f['adequate'],
                        rough='rough_cost' in f['warning_codes']))
    n = len(res)
    comp = [x for x in res if x['k'] is not None]
    print(f"logs {n}; contact chosen {len(comp)}; adequate {sum(bool(x['adequate']) for x in res)}; "
          f"fit time {sum(x['secs'] for x in res):.1f} s")
    print(f"kappa within 20 %: {sum(abs(x['k'] / x['kappa'] - 1) < 0.2 for x in comp)}/{len(comp)}; "
          f"interval covers: {sum(inside(x['k_iv'], x['kappa']) for x in comp)}/{len(comp)}")
    meas = [x for x in res if x['rs_fit'] is not None]
    unres = [x for x in comp if x['rs_fit'] is None]
    print(f"Rs measured {len(meas)}: covered {sum(inside(x['rs_iv'], x['rs']) for x in meas)}; "
          f"Rs only bounded {len(unres)}: bounds hold it {sum(inside(x['rs_iv'], x['rs']) for x in unres)}, "
          f"no bounds {sum(x['rs_iv'] is None for x in unres)}")
    print(f"Rd covered {sum(inside(x['rd_iv'], x['rd']) for x in res)}/{n}; "
          f"within 3 % {sum(abs(x['rd_fit'] / x['rd'] - 1) < 0.03 for x in res)}/{n}; "
          f"rough_cost {sum(x['rough'] for x in res)}")
    for x in res:
        print(f"  {os.path.basename(x['log'])} pre {x['pre_um']:.0f} um kappa {x['kappa']:.3f} -> {x['law']} "
              f"{x['k'] and round(x['k'], 3)} {x['k_iv'] and [round(v, 3) for v in x['k_iv']]} | Rs {x['rs']:.3f} "
              f"fit {x['rs_fit'] and round(x['rs_fit'], 3)} {x['rs_iv'] and [round(v, 3) for v in x['rs_iv']]} "
              f"| Rd {x['rd']:.3f} fit {x['rd_fit']:.4f} {x['rd_iv'] and [round(v, 3) for v in x['rd_iv']]} "
              f"| {'rough ' if x['rough'] else ''}{x['secs']} s")
    if os.environ.get('OUT_JSON'):
        json.dump(res, open(os.environ['OUT_JSON'], 'w'), indent=1)


def main(logs, fit, default_n):
    """DIR [N] [--fit]: writes N logs (default `default_n`) and fits them."""
    out = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else default_n
    rows = logs(out, n)
    if '--fit' in sys.argv:
        fit(rows)


if __name__ == '__main__':
    main(logs, fit, 24)
