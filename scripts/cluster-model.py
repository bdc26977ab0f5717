#!/usr/bin/env python3
"""Scaling model of a cluster simulation (docs/cluster.md): predicted wall time, memory and
communication per rank of a simulate job on 1…64 nodes, from rates measured on this machine.

    python3 scripts/cluster-model.py [--values-per-core 2.8e5] [--rays-per-core 4.8e6]
        [--cores 32] [--node-write 1e9] [--fs-write 1e10]

Measured inputs (docs/cluster.md gives the commands): the aBRDF values per second per core of
the adaptive simulator on brick, the hit-map rays per second per core. Assumed inputs, stated in
the table: cores per node, write bandwidth of one node and of the shared file system.
"""
import argparse

ap = argparse.ArgumentParser()
ap.add_argument("--values-per-core", type=float, default=2.8e5)
ap.add_argument("--rays-per-core", type=float, default=4.8e6)
ap.add_argument("--setup-seconds", type=float, default=5.0,
                help="per rank: network build and light solve, estimate calibration, start-up")
ap.add_argument("--cores", type=int, default=32)
ap.add_argument("--node-write", type=float, default=1e9, help="bytes/s one node writes")
ap.add_argument("--fs-write", type=float, default=1e10, help="bytes/s the file system takes")
a = ap.parse_args()

JOBS = [("512² × (16×32)²", 512 * 512, 512), ("256² × ubo151²", 256 * 256, 151)]
MAP_SAMPLES = 16      # 4×4 hit-map samples per texel (adaptive default)
MAP_BYTES = 16 + 4    # HitMaps::kBytesPerSample + kEdgeBytesPerSample
AGREEMENT_BYTES = 4096  # per rank: request, binary and scene checks, done flags, sums (measured ~1 KiB)


def fmt_s(s):
    return f"{s / 3600:.1f} h" if s >= 3600 else f"{s / 60:.1f} min" if s >= 60 else f"{s:.0f} s"


def fmt_b(b):
    for unit, f in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if b >= f:
            return f"{b / f:.1f} {unit}"
    return f"{b:.0f} B"


print(f"inputs: {a.values_per_core:.3g} values/s/core, {a.rays_per_core:.3g} rays/s/core "
      f"(measured, brick), {a.cores} cores/node, writes {fmt_b(a.node_write)}/s per node and "
      f"{fmt_b(a.fs_write)}/s for the file system (assumed), setup {a.setup_seconds:.0f} s/rank")
for name, texels, dirs in JOBS:
    values = texels * dirs * dirs
    out = values * 12
    rays = texels * dirs * MAP_SAMPLES
    maps = rays * MAP_BYTES
    vmf = texels * dirs * 8
    print(f"\n{name}: {values:.3g} values, raw store {fmt_b(out)}; per rank: hit maps "
          f"{fmt_b(maps)} + visibility map {fmt_b(vmf)} (the whole tile on every rank), "
          f"hit maps {fmt_s(rays / a.rays_per_core / a.cores)} (recomputed per rank)")
    print("| nodes | aBRDF | hit maps + setup | write | predicted wall | efficiency | "
          "communicated per rank |")
    print("|---|---|---|---|---|---|---|")
    t1 = None
    for n in (1, 2, 4, 8, 16, 32, 64):
        compute = values / (a.values_per_core * a.cores * n)
        fixed = rays / (a.rays_per_core * a.cores) + a.setup_seconds
        write = out / min(a.fs_write, a.node_write * n)
        # Writes overlap the compute (one chunk in flight): the slower of the two dominates.
        wall = fixed + max(compute, write)
        t1 = t1 or wall
        comm = AGREEMENT_BYTES * n
        share = out / n
        print(f"| {n} | {fmt_s(compute)} | {fmt_s(fixed)} | {fmt_s(write)} | {fmt_s(wall)} | "
              f"{100 * t1 / (n * wall):.0f} % | {fmt_b(comm)} ({100 * comm / share:.1e} % of its "
              f"{fmt_b(share)}) |")
