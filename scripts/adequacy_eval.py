"""Fits every log of an adequacy study (scripts/adequacy_study.py) with
BINARY and scores it against truth.json: usage adequacy_eval.py DIR BINARY."""
import json, subprocess, sys, os
B = sys.argv[2]; OUT = sys.argv[1]
rows = json.load(open(f'{OUT}/rows.json'))
truth = json.load(open(f'{OUT}/truth.json'))['files']
res = []
for name, fam, *_ in rows:
    p = subprocess.run([B, 'fit', name, '--json'], capture_output=True, text=True)
    f = json.loads(p.stdout); f = f['fits'][0] if 'fits' in f else f
    t = truth[os.path.basename(name)]
    trs, trd = t['law']['rs_n'], t['law']['rd_n']
    def miss(est, iv, tr):
        if est is None or iv is None: return None
        hw = (iv[1] - iv[0]) / 2
        return abs(est - tr) / hw if hw > 0 else float('inf')
    ad = f.get('adequacy') or {}
    m_rs = miss(f.get('r_s_n'), f.get('r_s_interval_n'), trs)
    m_rd = miss(f.get('r_d_n'), f.get('r_d_interval_n'), trd)
    res.append(dict(log=os.path.basename(name), fam=fam, law=f.get('law'), adequate=f.get('adequate'),
        stuck=f.get('stuck'), never_sticks=f.get('never_sticks'), true_stick=t['stick_fraction'],
        rs_err=None if f.get('r_s_n') is None else f['r_s_n'] / trs - 1, rd_err=None if f.get('r_d_n') is None else f['r_d_n'] / trd - 1,
        miss_rs=m_rs, miss_rd=m_rd, nr=(ad.get('noise_ratio_x1'), ad.get('noise_ratio_x2')),
        flagged=[(x['channel'], x['against'], round(x['z'], 1), round(x['effect'], 2)) for x in ad.get('structure', []) if 'force' not in x['channel'] and x['z'] > 3.7 and x['effect'] > 0.5],
        force=[(x['channel'], x['against'], round(x['z'], 1), round(x['effect'], 2)) for x in ad.get('structure', []) if 'force' in x['channel']],
        inflation=ad.get('interval_inflation'), codes=f.get('warning_codes', []),
        spring=[(f.get('spring_screen') or {}).get(k) for k in ('stiffness_change', 'z', 'flagged')]))
json.dump(res, open(f'{OUT}/eval.json', 'w'), indent=1)
n = len(res); adq = sum(bool(r['adequate']) for r in res)
for r in res:
    if r['adequate'] is None:
        print('  no verdict:', r['log'], r['fam'], '->', r['law'], 'stuck', r['stuck'], 'never_sticks', r['never_sticks'])
big = [r for r in res if max(r['miss_rs'] or 0, r['miss_rd'] or 0) > 2]
unflagged = [r for r in big if r['adequate']]
cov_rs = [r['miss_rs'] <= 1 for r in res if r['miss_rs'] is not None]
cov_rd = [r['miss_rd'] <= 1 for r in res if r['miss_rd'] is not None]
fam_ok = sum(1 for r in res if r['law'] == r['fam'])
nrs = sorted(max(v for v in r['nr'] if v is not None) for r in res if any(v is not None for v in r['nr']))
sz = sorted(abs(r['spring'][1]) for r in res if r['spring'][1] is not None)
print(f"rough_cost warnings: {sum('rough_cost' in (r['codes'] or []) for r in res)}")
print(f"spring screen: flagged {sum(bool(r['spring'][2]) for r in res)}, largest |z| {[round(v, 2) for v in sz[-5:]]}")
print(f'largest noise ratios (x1 or x2): {[round(v, 3) for v in nrs[-5:]]}')
print(f'logs {n}: adequate {adq} ({100*adq/n:.0f} %); family right {fam_ok}; Rs covered {sum(cov_rs)}/{len(cov_rs)}, Rd covered {sum(cov_rd)}/{len(cov_rd)}; misses > 2 half-widths {len(big)}, of them adequate (unflagged) {len(unflagged)}')
for r in res:
    if not r['adequate'] or max(r['miss_rs'] or 0, r['miss_rd'] or 0) > 1:
        print(' ', r['log'], r['fam'], '->', r['law'], 'adq', r['adequate'], 'stick', round(r['true_stick'], 3), 'rs', None if r['rs_err'] is None else round(100*r['rs_err'], 2), 'rd', None if r['rd_err'] is None else round(100*r['rd_err'], 2),
              'miss', None if r['miss_rs'] is None else round(r['miss_rs'], 1), None if r['miss_rd'] is None else round(r['miss_rd'], 1), 'nr', [round(v, 2) for v in r['nr'] if v], r['flagged'][:3], 'infl', r['inflation'])
json.dump(res, open(f'{OUT}/eval.json', 'w'), indent=1)
