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

Sampling is cosine-weighted (``sample``, ``pdf``); the tile-averaged importance sampling the
issue names is not done yet. In JIT variants the lookups leave Dr.Jit for numpy once per
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

        # The aBRDF at the shading points, light `light` and view `view` in the shading frame.
        def _abrdf(self, si, light, view):
            uv = _columns(si.uv, 2) * np.array(self.tiling)
            f = self.btf.values(uv, _columns(light, 3), _columns(view, 3), self.level)
            if dr.is_jit_v(mi.Float):
                return mi.Color3f(mi.Float(f[:, 0]), mi.Float(f[:, 1]), mi.Float(f[:, 2]))
            return mi.Color3f(float(f[0, 0]), float(f[0, 1]), float(f[0, 2]))

        def eval(self, ctx, si, wo, active=True):
            # Radiance transport: si.wi toward the camera (our view), wo toward the light.
            cos_i = mi.Frame3f.cos_theta(si.wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            value = self._abrdf(si, wo, si.wi) * dr.maximum(cos_o, 0.0)
            return dr.select(active & (cos_i > 0) & (cos_o > 0), value, mi.Color3f(0.0))

        def pdf(self, ctx, si, wo, active=True):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            p = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            return dr.select(active & (cos_i > 0) & (mi.Frame3f.cos_theta(wo) > 0), p, 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            bs = mi.BSDFSample3f()
            bs.wo = mi.warp.square_to_cosine_hemisphere(sample2)
            bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(bs.wo)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            ok = active & (cos_i > 0) & (bs.pdf > 0)
            # f · cos / pdf = aBRDF · π for cosine-weighted directions.
            weight = self._abrdf(si, bs.wo, si.wi) * dr.pi
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
