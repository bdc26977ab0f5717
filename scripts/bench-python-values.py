# Batched lookups from Python (docs/python.md "Speed"): 2 M lookups, median of 3.
# PYTHONPATH=build/python /usr/bin/python3 scripts/bench-python-values.py FILE.btf [ORDER]
#   ORDER random     uniform uv, cosine-uniform directions (the worst case for the caches)
#         scanline   the pixels of a 1414² image of a plane tiled 8 times, in scan order
#                    (neighbouring lookups on neighbouring texels), random directions
#         fixed      scanline, one light and one view for every pixel (a directional light and
#                    an orthographic camera)
import sys, time
import numpy as np
import btfstudio
b = btfstudio.open(sys.argv[1])
order = sys.argv[2] if len(sys.argv) > 2 else "random"
if order not in ("random", "scanline", "fixed"):
    sys.exit(f"bench-python-values: unknown order {order!r} (random, scanline or fixed)")
n = 2_000_000
rng = np.random.default_rng(0)
if order == "random":
    uv = rng.random((n, 2))
else:
    side = int(np.sqrt(n))
    y, x = np.mgrid[0:side, 0:side]
    uv = np.stack([(x.ravel() + .5) / side * 8, (y.ravel() + .5) / side * 8], 1)
    n = len(uv)
def hemi(n):
    t = np.arccos(rng.random(n)); p = rng.random(n) * 2 * np.pi
    return np.stack([np.sin(t)*np.cos(p), np.sin(t)*np.sin(p), np.cos(t)], 1)
if order == "fixed":
    wi = np.tile([0.3, 0.2, 0.93], (n, 1)); wo = np.tile([-0.5, 0.1, 0.86], (n, 1))
else:
    wi, wo = hemi(n), hemi(n)
b.values(uv[:1000], wi[:1000], wo[:1000])
ts = []
for k in range(3):
    t0 = time.perf_counter(); b.values(uv, wi, wo); ts.append(time.perf_counter() - t0)
print(f"{sys.argv[1]} ({b.codec}, {b.direction_set}, {b.nu}x{b.nv}, {order}): "
      f"{n / np.median(ts) / 1e6:.2f} M lookups/s (median of 3)")
