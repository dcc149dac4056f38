"""Velocity transducers with a miscalibrated gain (issue 30, item 2): two
rigs x N seeds, v2's gain drawn 3-12 % off 1 (either sign) against
controls with gains within the typical 1 %; the rest of the sensors
typical (synth's own draw of the seed), no accelerometer (M2's inertia
then comes from the differentiated v2, where the gain matters). Reports how often the gain is
found and corrected, the estimate's error against the truth (v2 gain over
x2 gain), and Rs/Rd within 3 % for the reported law and for the
equation-error estimate (whose inertia comes from the differentiated v2).

    python3 scripts/velocity_gain_study.py DIR [N]

B=path/to/stickslip picks the binary (default target/release/stickslip)."""
import json, os, random, subprocess, sys

B = os.environ.get('B', 'target/release/stickslip')
RIGS = {
    'public': dict(args=['--normal-force', '2.2'], rs=0.42 * 2.2, rd=0.34 * 2.2),
    'A': dict(args=['--m1-kg', '10', '--m2-kg', '2.5', '--k1-n-per-m', '1000', '--k2-n-per-m', '1000',
                    '--frequency-hz', '1.9', '--normal-force', '3.5', '--warmup-s', '30'],
              rs=0.42 * 3.5, rd=0.34 * 3.5),
}


def main(out, n):
    os.makedirs(out, exist_ok=True)
    rng = random.Random(30)
    rows = []
    for rig, spec in RIGS.items():
        for i in range(n):
            for kind in ('off', 'control'):
                seed = 700 + i
                mag = rng.uniform(0.03, 0.12) if kind == 'off' else rng.uniform(0.0, 0.01)
                g = 1.0 + mag * rng.choice([-1, 1])
                log = f'{out}/{rig}_{kind}_{i:02d}.mcap'
                if not os.path.exists(log):
                    # The seed's typical sensors, v2's gain replaced.
                    base = f'{out}/base_{rig}_{i}.mcap'
                    subprocess.run([B, 'synth', '--out', base, '--seed', str(seed), '--duration-s', '20',
                                    '--force'] + spec['args'], check=True, capture_output=True)
                    t = json.load(open(f'{out}/truth.json'))['files'][os.path.basename(base)]
                    sens = {}
                    for c in t['sensors'].values():
                        sens[c['quantity']] = {k: c[k] for k in (
                            'rate_hz', 'noise', 'quant', 'gain', 'offset', 'lowpass_hz', 'buffer_s',
                            'jitter_ns', 'p_lost_buffer', 'p_dropout', 'dropout_burst_max')}
                    for c in sens.values():
                        c.update(start_offset_ns=None, noise_correlation_s=0.0)
                    sens['v2']['gain'] = g
                    sens['a2'] = None  # no accelerometer: the inertia from d/dt v2
                    sj = log.replace('.mcap', '.sensors.json')
                    json.dump(sens, open(sj, 'w'))
                    subprocess.run([B, 'synth', '--out', log, '--seed', str(seed), '--duration-s', '20',
                                    '--sensors', sj, '--no-accelerometer'] + spec['args'], check=True, capture_output=True)
                    os.remove(base)
                t = json.load(open(f'{out}/truth.json'))['files'][os.path.basename(log)]
                g_true = {c['quantity']: c['gain'] for c in t['sensors'].values()}
                ratio = g_true['v2'] / g_true['x2']
                ing = json.loads(subprocess.run([B, 'ingest', '--json', log], capture_output=True, text=True).stdout)
                vc = ing['velocity_consistency']
                fit = json.loads(subprocess.run([B, 'fit', '--json', log], capture_output=True, text=True).stdout)
                f = fit['fits'][0]
                ee = f['equation_error']
                within = lambda v, t: v is not None and abs(v / t - 1) < 0.03
                rows.append(dict(rig=rig, kind=kind, ratio=ratio, gain=vc['gain'], se=vc['gain_se'],
                                 corrected=vc.get('gain_corrected'),
                                 rs=within(f['r_s_n'], spec['rs']), rd=within(f['r_d_n'], spec['rd']),
                                 ee_rs=within(ee and ee['r_s_n'], spec['rs']),
                                 ee_rd=within(ee and ee['r_d_n'], spec['rd']),
                                 ee_rd_rel=ee and ee['r_d_n'] and ee['r_d_n'] / spec['rd'] - 1))
    for rig in RIGS:
        for kind in ('off', 'control'):
            r = [x for x in rows if x['rig'] == rig and x['kind'] == kind]
            err = sorted(abs(x['gain'] - x['ratio']) for x in r)
            print(f"{rig:6} {kind:7} n {len(r)}: corrected {sum(bool(x['corrected']) for x in r)}; "
                  f"|gain - truth| median {err[len(err) // 2]:.5f} max {err[-1]:.5f}; "
                  f"Rs/Rd within 3 %: {sum(x['rs'] for x in r)}/{sum(x['rd'] for x in r)}; "
                  f"equation error {sum(x['ee_rs'] for x in r)}/{sum(x['ee_rd'] for x in r)} "
                  f"(worst Rd {max(abs(x['ee_rd_rel'] or 0) for x in r) * 100:.1f} %)")


if __name__ == '__main__':
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 10)
