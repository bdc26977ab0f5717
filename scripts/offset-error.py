#!/usr/bin/env python3
"""Error of a BTF file between its set directions (issue 37): REF is a simulation at another
direction set; FILE (.cbtf or .btf) is read at REF's directions (a neural file by its own
continuous decode, others interpolated between their set directions), over the pairs whose view
and light are both at θ ≤ --max-theta (the directions FILE's set covers: beyond its last ring
every codec extrapolates). Prints the relative RMSE over those pairs and the worst texel's.

  PYTHONPATH=build/python python3 scripts/offset-error.py REF.btf FILE.cbtf --max-theta 75
"""
import argparse
import sys

import numpy as np

import btfstudio

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("ref")
ap.add_argument("file")
ap.add_argument("--max-theta", type=float, default=90.0)
a = ap.parse_args()
ref, f = btfstudio.open(a.ref), btfstudio.open(a.file)
if (ref.nu, ref.nv) != (f.nu, f.nv):
    sys.exit(f"texel grids differ: {ref.nu}x{ref.nv} vs {f.nu}x{f.nv}")
dirs = ref.directions
keep = [k for k in range(len(dirs)) if dirs[k][0] <= a.max_theta]
se = np.zeros((ref.nv, ref.nu))
sr = np.zeros((ref.nv, ref.nu))
for v in keep:
    for l in keep:
        x = ref.slice(tuple(dirs[v]), tuple(dirs[l])).astype(np.float64)
        y = f.slice(tuple(dirs[v]), tuple(dirs[l])).astype(np.float64)
        se += ((x - y) ** 2).sum(axis=2)
        sr += (x ** 2).sum(axis=2)
rel = np.sqrt(se.sum() / sr.sum())
n = len(keep) ** 2 * 3
worst = np.sqrt(se.max() / n) / np.sqrt(sr.sum() / (n * se.size))
print(f"{len(keep)} of {len(dirs)} directions (θ ≤ {a.max_theta:g}°): relative RMSE "
      f"{100 * rel:.2f} %, worst texel RMSE / reference RMS {worst:.2f}")
