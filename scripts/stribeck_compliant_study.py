"""Stribeck pads behind a compliant contact (issue 34, session 31): eight
logs on the four rigs of adequacy_study.py, sensors drawn as there, a
contact spring whose pre-sliding Rs/kt is drawn between 15 and 150 µm.
No family of the fit is a Stribeck pad behind a spring unless the
Stribeck family's contact extension runs; the study measures what the fit
reads instead.

    python3 scripts/stribeck_compliant_study.py DIR [N]        # write the logs
    python3 scripts/stribeck_compliant_study.py DIR N --fit    # fit them, print the table

B=path/to/stickslip picks the binary (default target/release/stickslip)."""
import json, os, subprocess, sys, time

sys.path.insert(0, os.path.dirname(__file__))
sys.argv, ARGV = sys.argv[:1] + ['-', '1'], sys.argv  # adequacy_study reads argv on import
import compliant_study  # noqa: E402
sys.argv = ARGV

B = os.environ.get('B', 'target/release/stickslip')
compliant_study.B = B
inside = compliant_study.inside


def logs(out, n):
    # Stribeck pads (the draw's fourth family), their own seeds.
    return compliant_study.logs(out, n, ('stribeck', 3), 's', (3131, 700))


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
    compliant_study.main(logs, fit, 8)
