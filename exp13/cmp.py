import json,sys,re,glob,os
D='/work/scratch/lm13/runs/'
tags=sys.argv[1:] or ['nm','lm']
logs=sorted(set(os.path.basename(p).split('.')[0] if not p.endswith('N1.2.nm.json') else 'char_N1.2' for p in glob.glob(D+'*.nm.json')))
logs=sorted(set(re.sub(r'\.(nm|lm|hybrid|[a-z0-9_]+)\.json$','',os.path.basename(p)) for p in glob.glob(D+'*.nm.json')))
def load(b,t):
    j=json.load(open(D+f'{b}.{t}.json'))['fits'][0]
    err=open(D+f'{b}.{t}.err').read()
    cpu=re.search(r'CPU ([\d.]+) ([\d.]+)',err); cpu=float(cpu.group(1))+float(cpu.group(2))
    costs={}
    for m in re.finditer(r'^(\w+) pass 1 \w+: cost ([\d.eE+-]+)',err,re.M): costs[m.group(1)]=float(m.group(2))
    return j,cpu,costs
keys=['rho_s','rho_d','slope','r_s_n','r_d_n','slope_n_s_per_m']
ivk={'rho_s':'rho_s_interval','rho_d':'rho_d_interval','slope':'slope_interval','r_s_n':'r_s_interval_n','r_d_n':'r_d_interval_n','slope_n_s_per_m':'slope_interval_n_s_per_m'}
fam={'coulomb':'Coulomb','decreasing':'Decreasing','static-dynamic':'StaticDynamic','stribeck':'Stribeck'}
for b in logs:
    j0,c0,k0=load(b,'nm')
    oe0=j0.get('output_error')
    print(f'### {b}  estimate={j0.get("estimate")}')
    print('| setting | family | chosen cost | family costs (C/D/SD/St) | evals | CPU s | max |Δ|/hw | worst param | max hw ratio |')
    for t in tags:
        try: j,c,k=load(b,t)
        except Exception as e: print('|',t,'missing',e); continue
        oe=j.get('output_error')
        if not oe: print(f'| {t} | {j.get("law")} (no OE) | | | | {c:.2f} | | |'); continue
        ch=fam.get(oe['law'],oe['law'])
        worst=(0,'-'); hwr=0
        for kk in keys:
            a,b0=j.get(kk),j0.get(kk); iv=j0.get(ivk[kk]); iv1=j.get(ivk[kk])
            if a is None or b0 is None or not iv: continue
            hw=(iv[1]-iv[0])/2
            if hw<=0: continue
            d=abs(a-b0)/hw
            if d>=worst[0]: worst=(d,kk)
            if iv1: hwr=max(hwr,abs((iv1[1]-iv1[0])/2/hw-1))
        fc='/'.join(f'{k[f]:.3f}' if f in k else '-' for f in ['Coulomb','Decreasing','StaticDynamic','Stribeck'])
        print(f'| {t} | {oe["law"]} | {k.get(ch,float("nan")):.3f} | {fc} | {oe["evaluations"]} | {c:.2f} | {worst[0]:.3f} | {worst[1]} | {hwr:.2e} |')
    print()
