"""Stribeck pads behind a compliant contact (issue 34, session 31): eight
logs on the four rigs of adequacy_study.py, sensors drawn as there, a
contact spring whose pre-sliding Rs/kt is drawn between 15 and 150 µm.
No family of the fit is a Stribeck pad behind a spring unless the
Stribeck family's contact extension runs; the study measures what the fit
reads instead.

    python3 scripts/stribeck_compliant_study.py DIR [N]        # write the logs
    python3 scripts/stribeck_compliant_study.py DIR N --fit    # fit them, print the table

B=path/to/stickslip picks the binary (default target/release/stickslip)."""
import json, os, random, subprocess, sys, time

sys.path.insert(0, os.path.dirname(__file__))
sys.argv, ARGV = sys.argv[:1] + ['-', '1'], sys.argv  # adequacy_study reads argv on import
from adequacy_study import RIGS, draw  # noqa: E402
sys.argv = ARGV

B = os.environ.get('B', 'target/release/stickslip')


def logs(out, n):
    os.makedirs(out, exist_ok=True)
    rng = random.Random(3131)
    rows = []
    for i in range(n):
        # Stribeck pads (index 4·3 + rig): the draw's family cycle.
        args, s, fam = draw(rng, 12 + (i % len(RIGS)))
        assert fam == 'stribeck', fam
        rs = float(args[args.index('--rs-n') + 1])
        rd = float(args[args.index('--rd-n') + 1])
        pre = rng.uniform(15e-6, 150e-6)
        kt = rs / pre
        args += ['--contact-stiffness-n-per-m', str(kt)]
        name = f'{out}/s{i:03d}.mcap'
        sj = f'{out}/s{i:03d}.sensors.json'
        if not os.path.exists(name):
            json.dump(s, open(sj, 'w'))
            subprocess.run([B, 'synth', '--out', name, '--sensors', sj, '--seed', str(700 + i),
                            '--duration-s', '20'] + args, check=True, capture_output=True)
        rows.append(dict(log=name, rs=rs, rd=rd, kappa=kt / RIGS[i % len(RIGS)]['k2']))
    json.dump(rows, open(f'{out}/rows.json', 'w'), indent=1)
    return rows


def inside(iv, v):
    return iv is not None and iv[0] <= v <= iv[1]


def fit(rows):
    total = 0.0
    for r in rows:
        t0 = time.time()
        p = subprocess.run([B, 'fit', r['log'], '--json'], capture_output=True, text=True)
        dt = time.time() - t0
        total += dt
        f = json.loads(p.stdout)['fits'][0]
        rel = lambda v, t: 'None' if v is None else f'{v / t - 1:+.3f}'
        print(f"{os.path.basename(r['log'])} {f['law']:15s} adequate {str(f['adequate']):5s} "
              f"Rs {rel(f['r_s_n'], r['rs'])} {'covered' if inside(f['r_s_interval_n'], r['rs']) else 'MISSED'} | "
              f"Rd {rel(f['r_d_n'], r['rd'])} {'covered' if inside(f['r_d_interval_n'], r['rd']) else 'MISSED'} | "
              f"kappa {rel(f.get('contact_stiffness'), r['kappa'])} "
              f"{'covered' if inside(f.get('contact_stiffness_interval'), r['kappa']) else 'MISSED'} | {dt:.1f} s")
    print(f'fit time {total:.1f} s')


if __name__ == '__main__':
    out = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    rows = logs(out, n)
    if '--fit' in sys.argv:
        fit(rows)
