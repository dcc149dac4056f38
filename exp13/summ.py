import json,re,sys,glob,os
D='/work/scratch/lm13/runs/'
logs=['char_N1.2','char_N2.2','char_N4','char_N7.2','law_coulomb','law_decreasing','law_stribeck']
def costs(b,t):
    err=open(D+f'{b}.{t}.err').read()
    return {m.group(1):float(m.group(2)) for m in re.finditer(r'^(\w+) pass 1 \w+: cost ([\d.eE+-]+)',err,re.M)}, float(re.search(r'CPU ([\d.]+) ([\d.]+)',err).group(1))
for t in sys.argv[1:]:
    ev=0;cpu=0;gaps=[];same=True
    for b in logs:
        j=json.load(open(D+f'{b}.{t}.json'))['fits'][0]; j0=json.load(open(D+f'{b}.nm.json'))['fits'][0]
        ev+=j['output_error']['evaluations']; same&= j['law']==j0['law']
        c,cp=costs(b,t); c0,_=costs(b,'nm'); cpu+=cp
        for f in c0:
            d=c.get(f,float('nan'))-c0[f]
            if abs(d)>0.05: gaps.append(f'{b}/{f}:{d:+.2f}')
    print(f'{t}: evals {ev} cpu {cpu:.2f} same-family {same} gaps(vs nm, >0.05): {" ".join(gaps)}')
