"""Same-run A/B of RLS.run and update: run it in this tree and with PYTHONPATH=<old checkout>/src, alternating."""
import numpy as np, time, timeit, adaptid, json, sys
out={}
for n in (4,8,16):
    rng=np.random.default_rng(0); N=400000//max(1,n//4)
    Phi=rng.standard_normal((N,n)); y=Phi@rng.standard_normal(n)
    e=adaptid.RLS(n, forgetting=0.999); e.run(Phi[:100],y[:100],store=False)
    ts=[]
    for _ in range(7):
        e.reset(); t=time.perf_counter(); e.run(Phi,y,store=False); ts.append(time.perf_counter()-t)
    out[f"run{n}"]=N/min(ts)/1e6
e=adaptid.RLS(4); phi=np.array([0.3,-1.2,0.5,0.9])
out["update4_us"]=min(timeit.repeat(lambda: e.update(phi,1.0), number=20000, repeat=9))/20000*1e6
print(json.dumps({k: round(v,3) for k,v in out.items()}))
