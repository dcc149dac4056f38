"""Adequacy right both ways: in-family logs on several rigs with sensors
drawn from realistic specifications (not the estimator's noise model)."""
import json, subprocess, sys, os, random, math
B = os.environ.get('B', 'target/release/stickslip')
OUT = sys.argv[1]; N = int(sys.argv[2]) if len(sys.argv) > 2 else 60
RIGS = [  # m1, m2, k1, k2, D, drive amplitude, eta range
 dict(m1=8.35, m2=2.0875, k1=670, k2=670, D=0.003, A=0.0025),
 dict(m1=5, m2=1, k1=400, k2=400, D=0.005, A=0.0025),
 dict(m1=12, m2=2.5, k1=1500, k2=1000, D=0.002, A=0.003),
 dict(m1=3, m2=1, k1=200, k2=500, D=0.004, A=0.002),
]
FAMILIES = ['coulomb', 'static-dynamic', 'decreasing', 'stribeck']
def draw(rng, i):
    rig = RIGS[i % len(RIGS)]
    fam = FAMILIES[(i // len(RIGS)) % len(FAMILIES)]
    w = math.sqrt(rig['k2'] / rig['m2'])
    eta = rng.uniform(0.45, 0.75)
    f = eta * w / (2 * math.pi)
    rho_s = rng.uniform(0.25, 0.6)
    rs = rho_s * rig['A'] * rig['k2']
    rd = rs * (1.0 if fam == 'coulomb' else rng.uniform(0.6, 0.9))
    pos_rate = rng.choice([500.0, 1000.0, 2000.0])
    def sensor(rate, noise, quant, gain_err, off, lp=None, corr=0.0):
        return dict(rate_hz=rate, noise=noise, quant=quant, gain=1 + rng.uniform(-gain_err, gain_err),
                    offset=rng.uniform(-off, off), lowpass_hz=lp, buffer_s=rng.choice([0.05, 0.1, 0.2]),
                    start_offset_ns=None, jitter_ns=rng.choice([0, 2000, 10000]), p_lost_buffer=rng.choice([0.0, 0.005, 0.01]),
                    p_dropout=rng.choice([0.0, 2e-4]), dropout_burst_max=4, noise_correlation_s=corr)
    def pos():
        noise = rng.uniform(1e-6, 8e-6)
        lp = rng.choice([None, rng.uniform(100, 500)])
        corr = rng.choice([0.0, 0.0, rng.uniform(2e-4, 2e-3)])
        return sensor(pos_rate, noise, rng.choice([0.0, 0.3e-6, 1e-6, 2.5e-6]), 0.01, 2e-3, lp, corr)
    s = dict(x0=pos(), x1=pos(), x2=pos(),
             v2=sensor(rng.choice([500.0, 1000.0]), rng.uniform(1e-4, 6e-4), 1e-5, 0.01, 1e-4, rng.uniform(100, 300)),
             a2=rng.choice([None, sensor(2000.0, 0.02, 1e-3, 0.01, 0.01, 250.0)]),
             normal_force=dict(sensor(10.0, 0.0, 0.01, 0.008, 0.02), buffer_s=0.5, p_dropout=0.0))
    args = ['--m1-kg', rig['m1'], '--m2-kg', rig['m2'], '--k1-n-per-m', rig['k1'], '--k2-n-per-m', rig['k2'],
            '--d-n-s-per-m', rig['D'] * math.sqrt(rig['k2'] * rig['m2']), '--amplitude-m', rig['A'],
            '--frequency-hz', f, '--normal-force', 2.0, '--rs-n', rs, '--rd-n', rd, '--law', fam]
    if fam == 'decreasing':
        # D* between -0.05 and -0.01 (dimensionless), as N s/m: D*·sqrt(K2 M2)
        args += ['--slope-n-s-per-m', rng.uniform(-0.05, -0.01) * math.sqrt(rig['k2'] * rig['m2'])]
    if fam == 'stribeck':
        vs = rng.uniform(0.05, 0.3) * rig['A'] * w
        args += ['--stribeck-velocity-m-per-s', vs]
    return [str(a) for a in args], s, fam
def main():
    os.makedirs(OUT, exist_ok=True)
    rng = random.Random(2026)
    rows = []
    for i in range(N):
        args, s, fam = draw(rng, i)
        name = f'{OUT}/log{i:03d}.mcap'
        sj = f'{OUT}/log{i:03d}.sensors.json'
        if not os.path.exists(name):
            json.dump(s, open(sj, 'w'))
            subprocess.run([B, 'synth', '--out', name, '--sensors', sj, '--seed', str(100 + i)] + args,
                           check=True, capture_output=True)
        rows.append((name, fam, args))
    json.dump(rows, open(f'{OUT}/rows.json', 'w'))
if __name__ == "__main__": main()
