"""Our BTFs in Mitsuba 3 (docs/python.md): a BSDF plugin ``btf`` over btfstudio's batched lookups.

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")            # or "scalar_rgb"
    import btfstudio.mitsuba
    btfstudio.mitsuba.register()
    bsdf = {"type": "btf", "filename": "out/brick.btf", "tiling": "4,4", "level": 0}

What it models: the BTF's aBRDF at the shading point's texture coordinates (times ``tiling``,
periodic), bilinear between texels and interpolated between the set's directions — the values
``btfstudio.Btf.values`` and ``btfsim slice`` give — in the shading frame whose x axis follows the
surface's dp/du, front side only. What it does not: the relief's silhouettes and parallax (a BTF
on a flat shading point; ``btfsim render``'s mapped mode marches the shell for that), texel
levels chosen by footprint (one fixed ``level``), transmission.

Sampling (``sampling``: ``"importance"``, the default, or ``"cosine"``): the light direction is
drawn from the tile-averaged aBRDF of the set view nearest to the view, tabulated on a G x G grid
of the square that Mitsuba's cosine warp maps onto the hemisphere (``grid``, default 32), mixed
with cosine sampling (``cosine_fraction``, default 0.25) so that no direction where the BTF is
non-zero has zero density; ``pdf`` is that mixture's exact density. In JIT variants the lookups leave Dr.Jit for numpy once per
wavefront: register() turns Dr.Jit's symbolic loops and calls off (the integrators then run
evaluated, one kernel per bounce).
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np

import btfstudio


def _columns(v, n_cols: int) -> np.ndarray:
    """A Dr.Jit vector (scalar or JIT) as an N x n_cols float64 array."""
    a = np.array(v, dtype=np.float64)
    if a.ndim == 1:
        return a.reshape(1, n_cols)
    return a.T.copy() if a.shape[0] == n_cols and a.shape[-1] != n_cols else a


def _common(*arrays):
    """Row arrays broadcast to one length (Dr.Jit broadcasts width-1 arrays: a single si.wi with a
    wavefront of samples)."""
    n = max(len(a) for a in arrays)
    return [a if len(a) == n else np.broadcast_to(a, (n,) + a.shape[1:]).copy() for a in arrays]


def _tiling(props) -> tuple:
    if not "tiling" in props:
        return 1.0, 1.0
    t = props["tiling"]
    if isinstance(t, str):
        parts = [float(x) for x in t.replace(" ", "").split(",") if x]
    elif isinstance(t, (int, float)):
        parts = [float(t)]
    else:
        parts = [float(x) for x in t]
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2 or not all(np.isfinite(parts)) or min(parts) <= 0:
        raise btfstudio.BtfError(f"btf BSDF: tiling must be one or two positive numbers, got {t!r}")
    return parts[0], parts[1]


class TileAverageSampler:
    """Light directions drawn in proportion to the tile-averaged aBRDF, one table per set view.

    The square [0, 1)^2 of Mitsuba's cosine warp (square_to_cosine_hemisphere) is cut into G x G
    cells; for set view k, cell c holds T_k(c) = the luminance of the tile average at the cell's
    centre direction (the pyramid's last level: one texel, the box average of the tile), scaled to
    mean 1. The density over the square is p(u) = a + (1 - a) T_k(cell(u)) with a the cosine
    fraction, so the density over solid angle is p(u(ω)) cos θ / π — exact, and positive wherever
    cos θ > 0."""

    def __init__(self, btf, grid: int = 32, cosine_fraction: float = 0.25):
        if not 2 <= grid <= 256:
            raise btfstudio.BtfError(f"btf BSDF: grid must be within 2..256, got {grid}")
        if not 0.0 < cosine_fraction <= 1.0:
            raise btfstudio.BtfError(
                f"btf BSDF: cosine_fraction must be within (0, 1], got {cosine_fraction}")
        self.g = int(grid)
        self.a = float(cosine_fraction)
        dirs = btfstudio.directions_to_vectors(btf.directions)
        self.views = dirs[dirs[:, 2] > 1e-6]
        # Cell centres on the square → directions, through the same warp the sampler uses.
        c = (np.arange(self.g) + 0.5) / self.g
        ux, uy = np.meshgrid(c, c, indexing="xy")  # cell index = iy * g + ix
        sq = np.stack([ux.ravel(), uy.ravel()], 1)
        light = np.array(_columns(mi.warp.square_to_cosine_hemisphere(
            mi.Point2f(sq[:, 0], sq[:, 1])) if dr.is_jit_v(mi.Float) else _scalar_cosine(sq), 3))
        top = btf.levels - 1
        n_cells, n_views = len(sq), len(self.views)
        uv = np.full((n_cells * n_views, 2), 0.5)
        wi = np.tile(light, (n_views, 1))
        wo = np.repeat(self.views, n_cells, axis=0)
        f = btf.values(uv, wi, wo, top).reshape(n_views, n_cells, 3).mean(axis=2)
        f = np.where(np.isfinite(f), np.maximum(f, 0.0), 0.0)
        peak = f.max(axis=1, keepdims=True)
        f = np.maximum(f, 1e-4 * np.maximum(peak, 1e-30))
        self.table = f / f.mean(axis=1, keepdims=True)  # mean 1: ∫ T du = 1 over the square
        cdf = np.cumsum(self.table, axis=1)
        self.cdf = cdf / cdf[:, -1:]

    def view_index(self, view: np.ndarray) -> np.ndarray:
        """The nearest set view (largest cosine) of each view."""
        return np.argmax(view @ self.views.T, axis=1)

    def density_on_square(self, k: np.ndarray, sq: np.ndarray) -> np.ndarray:
        ix = np.clip((sq[:, 0] * self.g).astype(np.int64), 0, self.g - 1)
        iy = np.clip((sq[:, 1] * self.g).astype(np.int64), 0, self.g - 1)
        return self.a + (1 - self.a) * self.table[k, iy * self.g + ix]

    def sample_square(self, k: np.ndarray, s1: np.ndarray, s2: np.ndarray) -> np.ndarray:
        """Points of the square: s2 itself with probability a, else a cell drawn from the view's
        table (by s1 rescaled) and s2 placed within it."""
        sq = s2.copy()
        tab = s1 >= self.a
        if np.any(tab):
            r = (s1[tab] - self.a) / (1 - self.a)
            kk = k[tab]
            cell = np.empty(len(r), dtype=np.int64)
            for v in np.unique(kk):  # one searchsorted per view row
                m = kk == v
                cell[m] = np.searchsorted(self.cdf[v], r[m], side="right")
            cell = np.minimum(cell, self.g * self.g - 1)
            sq[tab, 0] = (cell % self.g + s2[tab, 0]) / self.g
            sq[tab, 1] = (cell // self.g + s2[tab, 1]) / self.g
        return np.clip(sq, 0.0, np.nextafter(1.0, 0.0))


def _scalar_cosine(sq: np.ndarray) -> np.ndarray:
    return np.array([list(mi.warp.square_to_cosine_hemisphere(mi.Point2f(float(a), float(b))))
                     for a, b in sq])


def _jit(a: np.ndarray, kind):
    """A numpy column as a Dr.Jit array of the variant (a Python float in scalar variants)."""
    if dr.is_jit_v(mi.Float):
        return kind(a)
    return float(a[0]) if kind is mi.Float else kind(a[0])


_CLASSES = {}


def bsdf_class():
    """The ``btf`` BSDF class of the current variant (mi.BSDF is one class per variant)."""
    variant = mi.variant()
    if variant is None:
        raise btfstudio.BtfError("btfstudio.mitsuba: call mi.set_variant(...) first")
    if variant in _CLASSES:
        return _CLASSES[variant]

    class BtfBSDF(mi.BSDF):
        """The ``btf`` BSDF: ``filename`` (.btf or .cbtf), ``tiling`` ("u,v" tiles per uv unit, or one
        number), ``level`` (texel level)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if not "filename" in props:
                raise btfstudio.BtfError("btf BSDF: the 'filename' property is required")
            self.filename = str(props["filename"])
            self.tiling = _tiling(props)
            self.level = int(props["level"]) if "level" in props else 0
            self.btf = btfstudio.open(self.filename)
            if not 0 <= self.level < self.btf.levels:
                raise btfstudio.BtfError(
                    f"btf BSDF: level {self.level} is outside 0..{self.btf.levels - 1} of {self.filename}")
            flags = (mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide |
                     mi.BSDFFlags.Anisotropic | mi.BSDFFlags.SpatiallyVarying)
            self.m_components = [flags]
            self.m_flags = flags
            mode = str(props["sampling"]) if "sampling" in props else "importance"
            if mode not in ("importance", "cosine"):
                raise btfstudio.BtfError(
                    f"btf BSDF: sampling must be 'importance' or 'cosine', got {mode!r}")
            self.sampler = None
            if mode == "importance":
                self.sampler = TileAverageSampler(
                    self.btf, int(props["grid"]) if "grid" in props else 32,
                    float(props["cosine_fraction"]) if "cosine_fraction" in props else 0.25)

        # The aBRDF at the shading points, light `light` and view `view` in the shading frame.
        def _abrdf(self, si, light, view):
            uv, li, vi = _common(_columns(si.uv, 2) * np.array(self.tiling), _columns(light, 3),
                                 _columns(view, 3))
            f = self.btf.values(uv, li, vi, self.level)
            if dr.is_jit_v(mi.Float):
                return mi.Color3f(mi.Float(f[:, 0]), mi.Float(f[:, 1]), mi.Float(f[:, 2]))
            return mi.Color3f(float(f[0, 0]), float(f[0, 1]), float(f[0, 2]))

        def eval(self, ctx, si, wo, active=True):
            # Radiance transport: si.wi toward the camera (our view), wo toward the light.
            cos_i = mi.Frame3f.cos_theta(si.wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            value = self._abrdf(si, wo, si.wi) * dr.maximum(cos_o, 0.0)
            return dr.select(active & (cos_i > 0) & (cos_o > 0), value, mi.Color3f(0.0))

        # The density over solid angle of the directions sample() draws (cos θ / π without tables).
        def _pdf(self, si, wo):
            p = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            if self.sampler is None:
                return p
            view, sq = _common(_columns(si.wi, 3), _columns(mi.warp.cosine_hemisphere_to_square(wo), 2))
            k = self.sampler.view_index(view)
            return p * _jit(self.sampler.density_on_square(k, sq), mi.Float)

        def pdf(self, ctx, si, wo, active=True):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            ok = active & (cos_i > 0) & (mi.Frame3f.cos_theta(wo) > 0)
            return dr.select(ok, self._pdf(si, wo), 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            bs = mi.BSDFSample3f()
            if self.sampler is None:
                bs.wo = mi.warp.square_to_cosine_hemisphere(sample2)
                bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(bs.wo)
                # f · cos / pdf = aBRDF · π for cosine-weighted directions.
                weight = self._abrdf(si, bs.wo, si.wi) * dr.pi
            else:
                view, s1, s2 = _common(_columns(si.wi, 3),
                                       np.atleast_1d(np.array(sample1, dtype=np.float64)),
                                       _columns(sample2, 2))
                sq = self.sampler.sample_square(self.sampler.view_index(view), s1, s2)
                bs.wo = mi.warp.square_to_cosine_hemisphere(
                    mi.Point2f(_jit(sq[:, 0], mi.Float), _jit(sq[:, 1], mi.Float)))
                # The density pdf() gives for bs.wo (the warp's round trip may cross a cell
                # boundary: the density of the direction, not of the square point, keeps
                # sample() and pdf() one function), and f · cos / pdf.
                bs.pdf = self._pdf(si, bs.wo)
                cos_o = dr.maximum(mi.Frame3f.cos_theta(bs.wo), 0.0)
                weight = self._abrdf(si, bs.wo, si.wi) * (cos_o / dr.maximum(bs.pdf, 1e-30))
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            ok = active & (cos_i > 0) & (bs.pdf > 0) & (mi.Frame3f.cos_theta(bs.wo) > 0)
            return bs, dr.select(ok, weight, mi.Color3f(0.0))

        def traverse(self, callback):
            pass

        def to_string(self):
            return (f"BtfBSDF[filename={self.filename!r}, tiling={self.tiling}, level={self.level}, "
                    f"{self.btf.codec}, {self.btf.nu}x{self.btf.nv} texels]")

    _CLASSES[variant] = BtfBSDF
    return BtfBSDF


def register() -> None:
    """Registers the ``btf`` BSDF with Mitsuba (after mi.set_variant) and, in JIT variants, runs
    loops and calls evaluated so that the lookups can leave Dr.Jit."""
    if dr.is_jit_v(mi.Float):
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    cls = bsdf_class()
    mi.register_bsdf("btf", lambda props: cls(props))
