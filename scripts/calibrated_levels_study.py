"""Levels per sliding direction from calibrated position zeros (issue 34):
round trips on the four rigs of adequacy_study.py. Each log declares
`position_zero_uncertainty_m` (drawn between 2 and 20 µm; the synth draws
the x0, x1, x2 offsets within it); the pads are static/dynamic with the
negative direction's levels 5–25 % apart from the positive one's (the
static and the dynamic level scaled by different amounts), and a third of
the logs are symmetric controls (how often a difference is claimed where
there is none). Sensors otherwise drawn as in adequacy_study.py.

    python3 scripts/calibrated_levels_study.py DIR [N]        # write the logs
    python3 scripts/calibrated_levels_study.py DIR N --fit    # fit them, print the table

B=path/to/stickslip picks the binary (default target/release/stickslip);
OUT_JSON=path keeps the per-log results."""
import json, os, random, subprocess, sys, time
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(__file__))
from adequacy_study import RIGS, draw  # noqa: E402

B = os.environ.get('B', 'target/release/stickslip')


def logs(out, n, seeds=(3535, 700)):
    os.makedirs(out, exist_ok=True)
    rng = random.Random(seeds[0])
    rows = []
    jobs = []
    for i in range(n):
        # static-dynamic pads (family index 1 in the draw's cycle)
        args, s, fam = draw(rng, 4 * 1 + (i % len(RIGS)))
        assert fam == 'static-dynamic', fam
        rs = float(args[args.index('--rs-n') + 1])
        rd = float(args[args.index('--rd-n') + 1])
        eps = rng.uniform(2e-6, 20e-6)
        control = i % 3 == 2
        if control:
            q_s = q_d = 0.0
        else:
            q = rng.uniform(0.05, 0.25) * rng.choice([-1.0, 1.0])
            q_s, q_d = q, q * rng.uniform(0.6, 1.4)
        rs_m, rd_m = rs * (1 - q_s), rd * (1 - q_d)
        if rd_m > rs_m:
            rd_m = rs_m
        args = [str(a) for a in args] + ['--position-zero-uncertainty-m', str(eps)]
        if not control:
            args += ['--rs-minus-n', str(rs_m), '--rd-minus-n', str(rd_m)]
        name = f'{out}/z{i:03d}.mcap'
        sj = f'{out}/z{i:03d}.sensors.json'
        if not os.path.exists(name):
            json.dump(s, open(sj, 'w'))
            jobs.append([B, 'synth', '--out', name, '--sensors', sj, '--seed', str(seeds[1] + i),
                         '--duration-s', '20'] + args)
        rows.append(dict(log=name, rig=i % len(RIGS), eps_um=eps * 1e6, control=control,
                         levels=[rs, rd, rs_m, rd_m]))
    with ThreadPoolExecutor(2) as ex:
        for p in ex.map(lambda c: subprocess.run(c, capture_output=True, text=True), jobs):
            if p.returncode != 0:
                raise SystemExit(p.stderr)
    json.dump(rows, open(f'{out}/rows.json', 'w'), indent=1)
    return rows


def inside(iv, v):
    return iv is not None and iv[0] <= v <= iv[1]


def fit_one(r):
    t0 = time.time()
    p = subprocess.run([B, 'fit', r['log'], '--json'], capture_output=True, text=True)
    f = json.loads(p.stdout)['fits'][0]
    keys = [('r_s_n', 'r_s_interval_n'), ('r_d_n', 'r_d_interval_n'),
            ('r_s_minus_n', 'r_s_minus_interval_n'), ('r_d_minus_n', 'r_d_minus_interval_n')]
    c = f.get('levels_by_direction') or {}
    return dict(r, secs=round(time.time() - t0, 2), law=f['law'], adequate=f['adequate'],
                gauge=f.get('levels_gauge'), resolved=c.get('resolved'), z=c.get('z'),
                fit=[f.get(k) for k, _ in keys], iv=[f.get(i) for _, i in keys])


def fit(rows):
    with ThreadPoolExecutor(2) as ex:
        return list(ex.map(fit_one, rows))


def table(res):
    names = ['Rs+', 'Rd+', 'Rs-', 'Rd-']
    asym = [r for r in res if not r['control']]
    ctrl = [r for r in res if r['control']]
    print(f"{'log':>5} {'rig':>3} {'eps':>5} {'gauge':>17} {'z':>6}  " +
          '  '.join(f'{n:>16}' for n in names))
    for r in res:
        cells = []
        for k in range(4):
            t, v, iv = r['levels'][k], r['fit'][k], r['iv'][k]
            if r['gauge'] != 'calibrated zeros':
                cells.append('-')
            elif v is None:
                cells.append(f"bnd {'ok' if inside(iv, t) else 'MISS'}")
            else:
                cells.append(f"{100 * (v / t - 1):+.2f}% {'ok' if inside(iv, t) else 'MISS'}")
        print(f"{os.path.basename(r['log'])[:4]:>5} {r['rig']:>3} {r['eps_um']:5.1f} "
              f"{str(r['gauge']):>17} {r['z'] or 0:6.2f}  " + '  '.join(f'{c:>16}' for c in cells)
              + ('  control' if r['control'] else ''))
    split = [r for r in asym if r['gauge'] == 'calibrated zeros']
    print(f"\nasymmetric pads: {len(split)}/{len(asym)} with levels per direction")
    measured = covered = within = bounded = bcov = 0
    for r in split:
        for k in range(4):
            t, v, iv = r['levels'][k], r['fit'][k], r['iv'][k]
            if v is None:
                bounded += 1
                bcov += inside(iv, t)
            else:
                measured += 1
                covered += inside(iv, t)
                within += abs(v / t - 1) <= 0.03
    print(f"levels measured {measured}: within 3 % {within}, covered {covered}; "
          f"bounded {bounded}: covered {bcov}")
    false = sum(1 for r in ctrl if r['gauge'] == 'calibrated zeros')
    print(f"symmetric controls: {false}/{len(ctrl)} claim a difference between the directions")
    print(f"fit time: median {sorted(r['secs'] for r in res)[len(res) // 2]} s, "
          f"max {max(r['secs'] for r in res)} s")


if __name__ == '__main__':
    out = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 30
    rows = logs(out, n)
    if '--fit' in sys.argv:
        res = fit(rows)
        if os.environ.get('OUT_JSON'):
            json.dump(res, open(os.environ['OUT_JSON'], 'w'), indent=1)
        table(res)
