# Batched lookups from Python (docs/python.md "Speed"): 2 M random lookups, median of 3.
# PYTHONPATH=build/python /usr/bin/python3 scripts/bench-python-values.py FILE.btf
import time, numpy as np, btfstudio, sys
b = btfstudio.open(sys.argv[1])
n = 2_000_000
rng = np.random.default_rng(0)
uv = rng.random((n, 2))
def hemi(n):
    t = np.arccos(rng.random(n)); p = rng.random(n) * 2 * np.pi
    return np.stack([np.sin(t)*np.cos(p), np.sin(t)*np.sin(p), np.cos(t)], 1)
wi, wo = hemi(n), hemi(n)
b.values(uv[:1000], wi[:1000], wo[:1000])
ts = []
for k in range(3):
    t0 = time.perf_counter(); b.values(uv, wi, wo); ts.append(time.perf_counter() - t0)
print(f"{sys.argv[1]} ({b.codec}, {b.direction_set}): {n / np.median(ts) / 1e6:.2f} M lookups/s (median of 3)")
