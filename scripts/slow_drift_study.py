"""Slow-sliding logs with a drifting velocity transducer (issue 30): two rigs
whose M2 peaks at about 5 mm/s, a v2 offset drifting by 0.2-0.4 mm/s per s
(4-8 mm/s over the 20 s log), 20 seeds each; fits them with BINARY and
scores Rs, Rd (3 %, interval coverage) and stuck/never-sticks claims.
Usage: slow_drift_study.py BINARY [N] in an empty directory; DS=0 gives the
drift-free controls, TAG a suffix for the log folders (docs/measurements.md)."""
import json, subprocess, random, os, sys
B = sys.argv[1]; N = int(sys.argv[2]) if len(sys.argv) > 2 else 20
rigs = {
 'A': ['--m1-kg','5','--m2-kg','1','--k1-n-per-m','400','--k2-n-per-m','400','--frequency-hz','2.3','--amplitude-m','0.0004','--rs-n','0.07','--rd-n','0.056'],
 'B': ['--m1-kg','12','--m2-kg','2.5','--k1-n-per-m','1000','--k2-n-per-m','1000','--frequency-hz','2.0','--amplitude-m','0.00035','--rs-n','0.2','--rd-n','0.16'],
}
rows = []
for rig, args in rigs.items():
    os.makedirs(rig + os.environ.get('TAG', ''), exist_ok=True)
    for seed in range(1, N + 1):
        rnd = random.Random(1000 * ord(rig) + seed)
        d = float(os.environ.get('DS', '1')) * rnd.choice([-1, 1]) * rnd.uniform(0.2e-3, 0.4e-3)
        log = f'{rig}{os.environ.get("TAG", "")}/s{seed}.mcap'
        if not os.path.exists(log):
            subprocess.run([B, 'synth', '--out', log, '--seed', str(seed), '--law', 'static-dynamic', '--offset-drift-per-s', f'v2={d}'] + args, check=True, capture_output=True)
        t = json.load(open(f'{rig}{os.environ.get("TAG", "")}/truth.json'))['files'][os.path.basename(log)]
        p = subprocess.run([B, 'fit', log, '--json'], capture_output=True, text=True)
        f = json.loads(p.stdout)['fits'][0]
        rs, rd = t['law']['rs_n'], t['law']['rd_n']
        cov = lambda iv, x: iv is not None and iv[0] <= x <= iv[1]
        r = dict(rig=rig, seed=seed, drift=d, stick=t['stick_fraction'], vmax=t['max_abs_v2_m_per_s'], law=f.get('law'), adequate=f.get('adequate'),
                 stuck=f.get('stuck'), never=f.get('never_sticks'), rs=f.get('r_s_n'), rd=f.get('r_d_n'),
                 rs_ok=f.get('r_s_n') is not None and abs(f['r_s_n'] / rs - 1) < 0.03, rd_ok=f.get('r_d_n') is not None and abs(f['r_d_n'] / rd - 1) < 0.03,
                 rs_cov=cov(f.get('r_s_interval_n'), rs), rd_cov=cov(f.get('r_d_interval_n'), rd), codes=f.get('warning_codes'))
        rows.append(r)
        print(rig, seed, 'drift %.2f mm/s/s' % (d * 1e3), 'stick %.3f vmax %.1f mm/s' % (r['stick'], r['vmax'] * 1e3), r['law'], r['adequate'], 'stuck', r['stuck'], 'never', r['never'],
              'Rs %+.2f %%' % (100 * (r['rs'] / rs - 1)) if r['rs'] else None, 'Rd %+.2f %%' % (100 * (r['rd'] / rd - 1)) if r['rd'] else None, r['rs_cov'], r['rd_cov'], flush=True)
json.dump(rows, open('rows.json', 'w'), indent=0)
for rig in rigs:
    rr = [r for r in rows if r['rig'] == rig]; n = len(rr)
    bad = sum(1 for r in rr if (r['stuck'] and r['stick'] < 0.99) or (r['never'] and r['stick'] > 0.01))
    print(f"{rig}: n {n}; Rs within 3 % {sum(r['rs_ok'] for r in rr)}, Rd {sum(r['rd_ok'] for r in rr)}; Rs covered {sum(r['rs_cov'] for r in rr)}, Rd {sum(r['rd_cov'] for r in rr)}; adequate {sum(bool(r['adequate']) for r in rr)}; stuck/never-sticks misclaims {bad}; drift warned {sum('velocity_drift' in (r['codes'] or []) for r in rr)}")
