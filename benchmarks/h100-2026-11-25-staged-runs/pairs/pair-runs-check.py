# The pairs variant's run sums (pairs.diff, pair_run_scatter) replayed on the host: 20,000 warps of
# 64 particles sorted by cell, some not live, each cell's sum checked against a plain sum. Prints "all ok".

import random
def sim(keys, live, vals):
    # keys[64], live[64], vals[64]; lane l holds a=2l, b=2l+1
    N=32
    ka=[keys[2*l] if live[2*l] else ('dead',2*l) for l in range(N)]
    kb=[keys[2*l+1] if live[2*l+1] else ('dead',2*l+1) for l in range(N)]
    same=[ka[l]==kb[l] for l in range(N)]
    kb_before=[kb[l-1] if l>0 else kb[0] for l in range(N)]  # shfl_up lane0 gets own
    handed=[(not same[l]) and l>0 and ka[l]==kb_before[l] for l in range(N)]
    handed_next=[(handed[l+1] if l<31 else handed[l]) and l<31 for l in range(N)]
    alone=[live[2*l] and not same[l] and not handed[l] for l in range(N)]
    va=[vals[2*l] for l in range(N)]; vb=[vals[2*l+1] for l in range(N)]
    sums=[(vb[l] if live[2*l+1] else 0)+(va[l] if same[l] else 0)+((va[l+1] if l<31 else va[l]) if handed_next[l] else 0) for l in range(N)]
    # warp run over kb
    out={}
    heads=[l==0 or kb[l-1]!=kb[l] for l in range(N)]
    l=0
    while l<N:
        m=l
        tot=0
        while m<N and kb[m]==kb[l]: tot+=sums[m]; m+=1
        if live[2*l+1]: out[kb[l]]=out.get(kb[l],0)+tot
        l=m
    for l in range(N):
        if alone[l]: out[ka[l]]=out.get(ka[l],0)+va[l]
    return out
random.seed(1)
for trial in range(20000):
    # sorted keys with runs of random length
    keys=[];k=0
    while len(keys)<64:
        k+=random.randint(1,3); keys+= [k]*random.randint(1,12)
    keys=keys[:64]
    live=[random.random()>0.1 for _ in range(64)]
    if random.random()<0.5:
        cut=random.randint(1,64)
        for i in range(cut,64): live[i]=False
    vals=[random.randint(1,1000) for _ in range(64)]
    truth={}
    for i in range(64):
        if live[i]: truth[keys[i]]=truth.get(keys[i],0)+vals[i]
    got=sim(keys,live,vals)
    if got!=truth:
        print("MISMATCH",trial,keys,live); break
else: print("all ok")
