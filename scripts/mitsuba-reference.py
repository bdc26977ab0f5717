#!/usr/bin/env python3
"""The mapped-vs-exact comparison in a renderer nobody here wrote (issue 38, docs/render.md
"An independent reference in Mitsuba 3").

For each scene and (view, light) pair, Mitsuba 3 renders the same orthographic view of an object
(``--object plane``, or ``cylinder``: btfsim's radius-0.7 cylinder, where the relief's silhouette
shows on the limbs) three ways and each is compared with the first:

  exact     the tile's real micro-geometry (btfstudio.tile_geometry: what the simulator traces),
            repeated over the plane (or wrapped around the cylinder: cut into slivers 1/16 of a
            tile wide so that its flat faces follow the curvature, cut at the cylinder's ends as
            btfsim's exact mode cuts it at the base mesh's edges), path traced with unbounded paths (``path``, max_depth -1);
            its noise floor from two seeds (RMS difference / sqrt 2)
  btf       the base surface (a rectangle; a 256 x 32 cylinder mesh) with our BTF through the ``btf`` plugin (btfstudio.mitsuba)
  measured  the base surface with Mitsuba's own ``measured`` BSDF reading our
            ``btfsim export --format rgl-bsdf`` file (the tile average: no texture)

next to ``btfsim render``'s own figures (mapped and flat against its exact mode, plane object,
same directions, object and tile size). Errors: relative RMSE over the image (sqrt(sum|a-b|^2 / sum|b|^2), RGB), per
pixel; and the error of the image mean (what a tile-averaged BRDF can at best get right).

  build/venv/bin/python scripts/mitsuba-reference.py [--build build] [--out out/mitsuba-ref]
      [--scenes brick,spheres] [--object plane|cylinder] [--size 160] [--spp 256]
      [--markdown FILE]

Materials: lambert is Mitsuba's ``diffuse``; blinn_phong is a BSDF written here with the formula
of docs/scene-format.md (kd/pi + ks (n+8)/(8 pi) cos^n theta_h); other types are refused.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

import mitsuba as mi

mi.set_variant("llvm_ad_rgb")
import drjit as dr  # noqa: E402

import btfstudio  # noqa: E402
import btfstudio.mitsuba  # noqa: E402

btfstudio.mitsuba.register()

# The pairs: (view θ, φ), (light θ, φ) in degrees. On the 6x16 axis grid of the resource scenes
# (θ = 0, 18, 36, 54, 72, 90 ... ) the first three are set directions; the last lies between them.
PAIRS = [((0, 0), (36, 0)), ((36, 180), (54, 0)), ((54, 90), (36, 202.5)), ((45, 200), (30, 20))]
WORLD_TILE = 0.25  # world length of one tile (x); the camera sees 1 world unit across
HALF = 2.5  # the plane spans [-HALF, HALF]^2: no edge in view even at 75 degrees


def unit(theta_deg: float, phi_deg: float) -> np.ndarray:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


class BlinnPhong(mi.BSDF):
    """kd/pi + ks (n+8)/(8 pi) cos^n theta_h, front side only, cosine sampling."""

    def __init__(self, props, kd, ks, n):
        mi.BSDF.__init__(self, props)
        self.kd = mi.Color3f(*kd)
        self.ks = mi.Color3f(*ks)
        self.n = float(n)
        flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
        self.m_components = [flags]
        self.m_flags = flags

    def _f(self, wi, wo):
        h = dr.normalize(wi + wo)
        lobe = dr.power(dr.maximum(mi.Frame3f.cos_theta(h), 0.0), self.n)
        return self.kd * dr.inv_pi + self.ks * ((self.n + 8) / (8 * dr.pi)) * lobe

    def eval(self, ctx, si, wo, active=True):
        ci, co = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(wo)
        return dr.select(active & (ci > 0) & (co > 0), self._f(si.wi, wo) * co, mi.Color3f(0.0))

    def pdf(self, ctx, si, wo, active=True):
        ci, co = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(wo)
        return dr.select(active & (ci > 0) & (co > 0),
                         mi.warp.square_to_cosine_hemisphere_pdf(wo), 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def sample(self, ctx, si, s1, s2, active=True):
        bs = mi.BSDFSample3f()
        bs.wo = mi.warp.square_to_cosine_hemisphere(s2)
        bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(bs.wo)
        bs.eta = 1.0
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
        bs.sampled_component = mi.UInt32(0)
        ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (bs.pdf > 0)
        return bs, dr.select(ok, self._f(si.wi, bs.wo) * dr.pi, mi.Color3f(0.0))

    def traverse(self, cb):
        pass

    def to_string(self):
        return "BlinnPhong[reference]"


def bsdf_of(name: str, m: dict) -> dict:
    if m["type"] == "lambert":
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(map(float, m["albedo"]))}}
    if m["type"] == "blinn_phong":
        key = "btfref_bp_" + "".join(c if c.isalnum() else "_" for c in name)
        kd, ks, n = m["diffuse"], m["specular"], m["exponent"]
        mi.register_bsdf(key, lambda props, kd=kd, ks=ks, n=n: BlinnPhong(props, kd, ks, n))
        return {"type": key}
    raise SystemExit(f"mitsuba-reference: material '{name}' of type '{m['type']}' has no Mitsuba "
                     "translation here (lambert and blinn_phong do)")


def mitsuba_mesh(name: str, P: np.ndarray, N: np.ndarray, F: np.ndarray, uv=None):
    mesh = mi.Mesh(name, len(P), len(F), has_vertex_normals=True, has_vertex_texcoords=uv is not None)
    prm = mi.traverse(mesh)
    prm["vertex_positions"] = dr.ravel(mi.TensorXf(P.astype(np.float32)))
    prm["vertex_normals"] = dr.ravel(mi.TensorXf(N.astype(np.float32)))
    if uv is not None:
        prm["vertex_texcoords"] = dr.ravel(mi.TensorXf(uv.astype(np.float32)))
    prm["faces"] = dr.ravel(mi.TensorXu(F.astype(np.uint32)))
    prm.update()
    return mesh


def tiled_meshes(scene_path: str) -> dict:
    """The tile's triangles repeated over [-HALF, HALF]^2, one Mitsuba mesh per material."""
    g = btfstudio.tile_geometry(scene_path)
    lx, ly = g["size"]
    k = WORLD_TILE / lx  # world length of one tile unit (isotropic: the relief keeps its shape)
    nx, ny = int(round(2 * HALF / (lx * k))), int(round(2 * HALF / (ly * k)))
    pos, nrm, tri, mat = g["positions"], g["normals"], g["triangles"], g["materials"]
    shapes = {}
    for mi_, name in enumerate(g["material_names"]):
        sel = tri[mat == mi_]
        if len(sel) == 0:
            continue
        used, inv = np.unique(sel.ravel(), return_inverse=True)
        p0, n0, f0 = pos[used].astype(np.float64), nrm[used], inv.reshape(-1, 3).astype(np.uint32)
        copies_p, copies_f = [], []
        for j in range(-1, ny + 1):
            for i in range(-1, nx + 1):
                p = p0.copy()
                p[:, 0] = (p[:, 0] + i * lx) * k - HALF
                p[:, 1] = (p[:, 1] + j * ly) * k - HALF
                p[:, 2] = p[:, 2] * k
                copies_f.append(f0 + len(p0) * len(copies_p))
                copies_p.append(p)
        mesh = mitsuba_mesh(name, np.concatenate(copies_p), np.tile(n0, (len(copies_p), 1)),
                            np.concatenate(copies_f))
        mesh.set_bsdf(mi.load_dict(bsdf_of(name, g["scene"]["materials"][name])))
        shapes["micro_" + str(mi_)] = mesh
    return shapes, (nx, ny)


# btfsim's cylinder (engine/btf/render/objects.cpp): radius 0.7, z in [-1, 1], uv = (2 s, t 2 / (0.7 pi))
# for s = phi / 2 pi and t = (z + 1) / 2: isometric, one uv unit = 0.7 pi world units.
CYL_R = 0.7
CYL_UV = 0.7 * math.pi
CYL_V = 2.0 / CYL_UV  # the v range
CYL_HALF_VIEW = 0.85  # the orthographic half height: the ends (z = +-1) stay out of a side view
CYL_SLIVERS = 16  # slivers per tile width that the wrapped faces are cut into
CYL_PAIRS = [((90, -90), (45, -90)), ((90, -90), (60, -20)), ((80, -60), (30, -150))]


def _clip(poly: list, axis: int, c: float, keep_above: bool) -> list:
    """Sutherland-Hodgman against the line coordinate[axis] = c; vertices are (position, normal)
    tuples of numpy 3-vectors. An edge's crossing is computed from its endpoints in a fixed order,
    so the two faces that share the edge get the same point (no crack)."""
    out = []
    inside = lambda v: (v[0][axis] >= c) if keep_above else (v[0][axis] <= c)  # noqa: E731
    for k in range(len(poly)):
        a, b = poly[k], poly[(k + 1) % len(poly)]
        ia, ib = inside(a), inside(b)
        if ia:
            out.append(a)
        if ia != ib:
            lo, hi = (a, b) if tuple(a[0]) < tuple(b[0]) else (b, a)
            t = (c - lo[0][axis]) / (hi[0][axis] - lo[0][axis])
            n = lo[1] + t * (hi[1] - lo[1])
            out.append((lo[0] + t * (hi[0] - lo[0]), n / max(np.linalg.norm(n), 1e-30)))
    return out


def _fans(polys: list):
    P, N, F = [], [], []
    for poly in polys:
        if len(poly) < 3:
            continue
        base = len(P)
        for p, n in poly:
            P.append(p), N.append(n)
        for k in range(1, len(poly) - 1):
            F.append((base, base + k, base + k + 1))
    return (np.array(P, dtype=np.float64).reshape(-1, 3), np.array(N, dtype=np.float64).reshape(-1, 3),
            np.array(F, dtype=np.int64).reshape(-1, 3))


def cylinder_meshes(scene_path: str, tiling: int) -> dict:
    """The tile's triangles wrapped around btfsim's cylinder at `tiling` tiles per uv unit (2 tiling
    tiles around), as btfsim's exact mode maps them: tile point (x, y, h) at angle pi x / (T Lx),
    height -1 + y k and radius 0.7 + h k (k = 0.7 pi / (T Lx) world units per tile unit), normals
    in the frame (dp/du, dp/dv, outward normal). The faces are first cut into slivers 1/16 of a
    tile wide (a flat face across a whole tile would cut a chord through the curve), then cut at
    the ends."""
    g = btfstudio.tile_geometry(scene_path)
    lx, ly = g["size"]
    k = CYL_UV / (tiling * lx)
    y_max = CYL_V * tiling * lx  # the base's v range in tile units
    pos, nrm, tri, mat = g["positions"].astype(np.float64), g["normals"].astype(np.float64), g["triangles"], g["materials"]
    step = lx / CYL_SLIVERS
    shapes = {}
    for mi_, name in enumerate(g["material_names"]):
        polys = []
        for t in tri[mat == mi_]:
            poly = [(pos[i].copy(), nrm[i].copy()) for i in t]
            x0, x1 = min(p[0][0] for p in poly), max(p[0][0] for p in poly)
            for m in range(int(math.floor(x0 / step)) + 1, int(math.ceil(x1 / step))):
                left = _clip(poly, 0, m * step, False)
                if len(left) >= 3:
                    polys.append(left)
                poly = _clip(poly, 0, m * step, True)
                if len(poly) < 3:
                    break
            if len(poly) >= 3:
                polys.append(poly)
        if not polys:
            continue
        y_lo = min(p[0][1] for q in polys for p in q)
        y_hi = max(p[0][1] for q in polys for p in q)
        rows_P, rows_N, rows_F = [], [], []
        for j in range(int(math.floor(-y_hi / ly)), int(math.ceil((y_max - y_lo) / ly)) + 1):
            oy = j * ly
            if y_lo + oy >= 0 and y_hi + oy <= y_max:
                row = polys
            else:  # a row the ends cut: clip every piece to 0 <= y + oy <= y_max
                row = []
                for q in polys:
                    q = _clip(q, 1, -oy, True)
                    if len(q) >= 3:
                        q = _clip(q, 1, y_max - oy, False)
                    if len(q) >= 3:
                        row.append(q)
            P, N, F = _fans(row)
            if len(F) == 0:
                continue
            P = P.copy()
            P[:, 1] += oy
            rows_P.append(P), rows_N.append(N), rows_F.append(F)
        copies_p, copies_n, copies_f, nv = [], [], [], 0
        for P, N, F in zip(rows_P, rows_N, rows_F):
            for i in range(2 * tiling):
                x = P[:, 0] + i * lx
                phi = math.pi * x / (tiling * lx)
                c, s = np.cos(phi), np.sin(phi)
                r = CYL_R + P[:, 2] * k
                copies_p.append(np.stack([r * c, r * s, -1 + P[:, 1] * k], 1))
                # tile frame -> world: x along dp/du = (-sin, cos, 0), y along z, z outward
                copies_n.append(np.stack([-N[:, 0] * s + N[:, 2] * c, N[:, 0] * c + N[:, 2] * s, N[:, 1]], 1))
                copies_f.append(F + nv)
                nv += len(P)
        mesh = mitsuba_mesh(name, np.concatenate(copies_p), np.concatenate(copies_n), np.concatenate(copies_f))
        mesh.set_bsdf(mi.load_dict(bsdf_of(name, g["scene"]["materials"][name])))
        shapes["micro_" + str(mi_)] = mesh
    return shapes


def cylinder_base(bsdf: dict, tiling: int):
    """btfsim's base cylinder at a finer grid (256 x 32), with its texture coordinates."""
    nu, nv = 256, 32
    s, t = np.meshgrid(np.arange(nu + 1) / nu, np.arange(nv + 1) / nv, indexing="xy")
    s, t = s.ravel(), t.ravel()
    ph = 2 * math.pi * s
    N = np.stack([np.cos(ph), np.sin(ph), np.zeros_like(ph)], 1)
    P = np.stack([CYL_R * N[:, 0], CYL_R * N[:, 1], 2 * t - 1], 1)
    uv = np.stack([2 * s, t * CYL_V], 1)
    F = []
    for j in range(nv):
        for i in range(nu):
            a = j * (nu + 1) + i
            F += [(a, a + 1, a + nu + 2), (a, a + nu + 2, a + nu + 1)]
    mesh = mitsuba_mesh("base", P, N, np.array(F), uv)
    mesh.set_bsdf(mi.load_dict(dict(bsdf, tiling=f"{tiling},{tiling}") if bsdf["type"] == "btf" else bsdf))
    return mesh


def sensor(view, size, spp, seed, half=0.5):
    v = unit(*view)
    up = [0, 1, 0] if view[0] < 1e-6 else [0, 0, 1]
    return {"type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=(10 * v).tolist(), target=[0, 0, 0], up=up)
            @ mi.ScalarTransform4f().scale([half, half, 1]),
            "sampler": {"type": "stratified", "sample_count": spp, "seed": seed},
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"}}


def render(shapes, view, light, size, spp, seed, depth, half=0.5):
    l = unit(*light)
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": depth},
             "sensor": sensor(view, size, spp, seed, half),
             "sun": {"type": "directional", "direction": (-l).tolist(),
                     "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}}
    scene.update(shapes)
    t0 = time.perf_counter()
    img = np.array(mi.render(mi.load_dict(scene), spp=spp, seed=seed))[:, :, :3]
    return img.astype(np.float64), time.perf_counter() - t0


def rel_rmse(a, b) -> float:
    return float(np.sqrt(np.sum((a - b) ** 2) / max(np.sum(b ** 2), 1e-30)))


def rel_mean(a, b) -> float:
    return float(abs(a.mean() - b.mean()) / max(b.mean(), 1e-30))


def btfsim_render(build, btf, view, light, size, spp, out, obj="plane", tiling=None, half=0.5):
    """btfsim render's object at the same tile size and the same view: its exact, mapped and flat
    images (top row first) and its own errors against its exact mode. The plane ([-1, 1]^2,
    radius sqrt 2) at tiling 8 (a tile is 0.25 world units); the cylinder (radius sqrt(0.7^2 + 1))
    at `tiling`. The zoom makes the half height `half`."""
    radius = math.sqrt(2) if obj == "plane" else float(np.float32(math.sqrt(CYL_R ** 2 + 1)))
    zoom = 1.05 * radius / half
    if tiling is None:
        tiling = int(round(2 / WORLD_TILE))
    js = subprocess.run([f"{build}/app/btfsim", "render", btf, "-o", out, "--mode", "all", "--object",
                         obj, "--camera", f"{view[0]},{view[1]}", "--light", f"{light[0]},{light[1]}",
                         "--size", str(size), "--spp", str(spp), "--tiling", str(tiling),
                         "--zoom", f"{zoom:.7f}", "-q", "--json"],
                        check=True, capture_output=True, text=True).stdout
    own = {}
    for im in json.loads(js)["images"]:
        e = im.get("error_vs_exact")
        if e:
            own[im["mode"]] = e["rel_rmse"]
    stem = out[:-4]
    imgs = {m: btfstudio.read_image(f"{stem}.{m}.exr").astype(np.float64) for m in ("exact", "mapped", "flat")}
    return imgs, own


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/mitsuba-ref")
    ap.add_argument("--scenes", default="brick,spheres")
    ap.add_argument("--object", default="plane", choices=("plane", "cylinder"))
    ap.add_argument("--tiling", type=int, default=6, help="the cylinder's tiles per uv unit")
    ap.add_argument("--size", type=int, default=160)
    ap.add_argument("--spp", type=int, default=256, help="the exact image's samples per pixel")
    ap.add_argument("--pairs", type=int, default=None, help="the first N pairs only")
    ap.add_argument("--markdown", default=None, help="also write the table to this file")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    sim = f"{a.build}/app/btfsim"
    cyl = a.object == "cylinder"
    pairs = (CYL_PAIRS if cyl else PAIRS)[:a.pairs]
    half = CYL_HALF_VIEW if cyl else 0.5
    if cyl and a.tiling < 1:
        raise SystemExit("mitsuba-reference: --tiling must be a positive integer")
    flags = f" --object cylinder --tiling {a.tiling}" if cyl else ""
    lines = [f"Generated by `build/venv/bin/python scripts/mitsuba-reference.py{flags} --size {a.size} --spp {a.spp}` "
             f"({time.strftime('%Y-%m-%d', time.gmtime())}, {os.cpu_count()} cores, Mitsuba {mi.__version__}, "
             "llvm_ad_rgb).", "",
             "Every figure is the relative RMSE against Mitsuba's path-traced micro-geometry (per pixel), "
             "in brackets btfsim's own figure against its exact mode; *mean* is the error of the image "
             "mean (btfsim exact / btfsim mapped / btf plugin / measured).", "",
             "| scene | view (θ, φ) | light (θ, φ) | Mitsuba exact noise floor | btfsim exact | btfsim mapped "
             "| btfsim flat | Mitsuba + btf plugin | Mitsuba measured (.bsdf) | mean | Mitsuba exact s | plugin s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name in a.scenes.split(","):
        scene_path = f"resources/scenes/{name}.json"
        btf = f"{a.out}/{name}.btf"
        bsdf = f"{a.out}/{name}.bsdf"
        if not os.path.exists(btf):
            subprocess.run([sim, "simulate", scene_path, "-o", btf, "-q"], check=True)
        if not os.path.exists(bsdf):
            subprocess.run([sim, "export", btf, "--format", "rgl-bsdf", "-o", bsdf, "-q"], check=True)
        t0 = time.perf_counter()
        if cyl:
            micro = cylinder_meshes(scene_path, a.tiling)
            btf_shape = cylinder_base({"type": "btf", "filename": btf}, a.tiling)
            meas_shape = cylinder_base({"type": "measured", "filename": bsdf}, a.tiling)
        else:
            micro, (nx, ny) = tiled_meshes(scene_path)
            plane = {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([HALF, HALF, 1])}
            btf_shape = dict(plane, bsdf={"type": "btf", "filename": btf, "tiling": f"{nx},{ny}"})
            meas_shape = dict(plane, bsdf={"type": "measured", "filename": bsdf})
        print(f"{name}: {sum(m.face_count() for m in micro.values())} micro-triangles "
              f"({time.perf_counter() - t0:.1f} s)", flush=True)
        for view, light in pairs:
            exact, t_exact = render(micro, view, light, a.size, a.spp, 1, -1, half)
            exact2, _ = render(micro, view, light, a.size, a.spp, 2, -1, half)
            floor = rel_rmse(exact, exact2) / math.sqrt(2)
            ref = 0.5 * (exact + exact2)
            img_btf, t_btf = render({"base": btf_shape}, view, light, a.size, 16, 1, 2, half)
            img_meas, _ = render({"base": meas_shape}, view, light, a.size, 16, 1, 2, half)
            tag = f"{name}_{a.object}_v{view[0]}_{view[1]}_l{light[0]}_{light[1]}"
            np.save(f"{a.out}/{tag}.npy", np.stack([ref, img_btf, img_meas]))
            bimg, own = btfsim_render(a.build, btf, view, light, a.size, a.spp,
                                      f"{a.out}/{tag}.btfsim.png", a.object,
                                      a.tiling if cyl else None, half)
            e = lambda im: f"{100 * rel_rmse(im, ref):.1f} %"  # noqa: E731
            m = lambda im: f"{100 * rel_mean(im, ref):.1f} %"  # noqa: E731
            row = (f"| {name} | {view[0]}°, {view[1]}° | {light[0]}°, {light[1]}° | {100 * floor:.2f} % "
                   f"| {e(bimg['exact'])} | {e(bimg['mapped'])} ({100 * own['mapped']:.1f} %) "
                   f"| {e(bimg['flat'])} | {e(img_btf)} | {e(img_meas)} "
                   f"| {m(bimg['exact'])} / {m(bimg['mapped'])} / {m(img_btf)} / {m(img_meas)} "
                   f"| {t_exact:.1f} | {t_btf:.1f} |")
            lines.append(row)
            print(row, flush=True)
    text = "\n".join(lines) + "\n"
    print(text)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
