"""BTF Studio from Python (docs/python.md).

    import btfstudio
    b = btfstudio.open("out/brick.btf")          # a .btf store or any .cbtf (levels too)
    img = b.slice(view=(30, 90), light=(45, 0))  # nv x nu x 3 float32, as `btfsim slice` writes
    rep = btfstudio.run("simulate", scene="resources/scenes/brick.json", output="b.btf",
                        texels=16, dirs="4x8", progress=print)

Every command of `btfsim` is a function here too (``btfstudio.simulate(...)``), its options,
defaults, ranges and docs taken from the same declarations as the CLI's (``help(btfstudio.plan)``).
Errors are :class:`BtfError` with the CLI's one-line message; a run cancelled (a progress callback
returning False, or Ctrl-C) raises :class:`Cancelled` or the KeyboardInterrupt and leaves no
output file and no ``.partial`` behind.
"""

from __future__ import annotations

import math
import os
import numbers
from typing import Any, Callable, Optional

import numpy as np

from . import _core
from ._core import BtfError, Cancelled

__all__ = ["open", "Btf", "run", "commands", "BtfError", "Cancelled", "directions_to_vectors",
           "read_image"]

_DECLS = {c["name"]: c for c in _core.commands()}


def commands() -> dict:
    """Every command's declaration: {name: {"doc", "positional", "options": [...]}}."""
    return {k: dict(v) for k, v in _DECLS.items()}


def directions_to_vectors(deg: np.ndarray) -> np.ndarray:
    """(θ, φ) in degrees (N x 2) to unit vectors of the tile's frame (N x 3, z up)."""
    d = np.radians(np.asarray(deg, dtype=np.float64))
    st = np.sin(d[:, 0])
    return np.stack([st * np.cos(d[:, 1]), st * np.sin(d[:, 1]), np.cos(d[:, 0])], axis=1)


class Btf:
    """A BTF file: ``open(path)``. Values are aBRDF (1/sr, linear RGB, cosine not included)."""

    def __init__(self, path: str, memory_budget: str = "4G"):
        self._b = _core.Btf(os.fspath(path), memory_budget)

    # --- what the file is -------------------------------------------------------------------
    path = property(lambda self: self._b.path)
    codec = property(lambda self: self._b.codec, doc="'raw' for a .btf store, else the codec")
    levels = property(lambda self: self._b.levels, doc="texel levels that open (0 = finest)")
    pyramid = property(lambda self: self._b.pyramid, doc="a .cbtf that stores its own levels")
    nu = property(lambda self: self._b.nu)
    nv = property(lambda self: self._b.nv)
    texels = property(lambda self: self._b.texels, doc="nu x nv of level 0")
    direction_set = property(lambda self: self._b.direction_set)

    @property
    def directions(self) -> np.ndarray:
        """N x 2 (θ, φ) in degrees, the same set for views and lights."""
        return self._b.directions

    @property
    def header(self) -> dict:
        """The file's header (scene, settings, provenance) as a dict."""
        import json

        return json.loads(self._b.header)

    def level_size(self, level: int) -> tuple:
        """(nu, nv) of a texel level."""
        return self._b.level_size(level)

    def __repr__(self) -> str:
        return (f"<btfstudio.Btf {self.path!r}: {self.codec}, {self.nu}x{self.nv} texels, "
                f"{len(self.directions)} directions ({self.direction_set}), {self.levels} levels>")

    # --- reading it -------------------------------------------------------------------------
    def slice(self, view, light, level: int = 0) -> np.ndarray:
        """The spatial image at one (view, light) pair, each (θ, φ) in degrees: nv x nu x 3
        float32, top row first, the values ``btfsim slice --view θ,φ --light θ,φ`` writes in its
        EXR (interpolated between the set's directions)."""
        return self._b.slice(_pair(view, "view"), _pair(light, "light"), level)

    def texel(self, u: int, v: int, level: int = 0) -> np.ndarray:
        """Texel (u, v) (column u, row v counted from the bottom, as the store): its matrix
        [view, light, rgb] over the file's directions (self.directions)."""
        return self._b.texel(int(u), int(v), level)

    def brdf(self, level: int = 0) -> np.ndarray:
        """The tile-averaged aBRDF [view, light, rgb] over the file's directions."""
        return self._b.brdf(level)

    def values(self, uv, wi, wo, level: int = 0) -> np.ndarray:
        """Batched lookups: uv (N x 2, fractions of the tile, periodic), wi the light and wo the
        view (N x 3 unit vectors, z up) → N x 3 float32 aBRDF, bilinear between texels and
        interpolated between the set's directions as the renderer does; 0 at or below the
        horizon."""
        return self._b.values(np.atleast_2d(np.asarray(uv, dtype=np.float64)),
                              np.atleast_2d(np.asarray(wi, dtype=np.float64)),
                              np.atleast_2d(np.asarray(wo, dtype=np.float64)), level)

    def vmf(self) -> Optional[np.ndarray]:
        """The visibility map: [direction, v, u, (coverage, mean depth)] — a raw store's, or the
        one a .cbtf carries (coverage and depth coded in 8 bits); None for a flat tile (it needs
        none) or a .cbtf written before files carried it."""
        return self._b.vmf()


def read_image(path) -> np.ndarray:
    """An EXR, PNG or JPEG as H x W x 3 float32, top row first (linear for EXR), read by the
    engine's careful reader (sizes checked before anything is allocated)."""
    return _core.read_image(os.fspath(path))


def tile_geometry(scene) -> dict:
    """The scene file's tile as the simulator builds it (periodic in x and y with ``size``):
    ``positions`` and ``normals`` (V x 3 float32, tile units, z up; normals the shading normals),
    ``triangles`` (T x 3 uint32), ``materials`` (T uint16, indices into ``material_names``),
    ``z_range``, and ``scene``: the canonical scene (every parameter written) as a dict."""
    import json
    d = dict(_core.tile_geometry(os.fspath(scene)))
    d["scene"] = json.loads(d.pop("scene_json"))
    return d


def open(path: str, memory_budget: str = "4G") -> Btf:  # noqa: A001 (the package's verb)
    """Opens a .btf store or a .cbtf file of any codec (raises BtfError naming what is wrong)."""
    return Btf(path, memory_budget)


def _pair(p, what: str) -> tuple:
    try:
        t, f = p
        return float(t), float(f)
    except (TypeError, ValueError):
        raise BtfError(f"{what}: expected (θ, φ) in degrees, got {p!r}") from None


def _text(value: Any, repeatable: bool) -> str:
    """An option's value as the CLI's text: numbers shortest round-trip, pairs "a,b", repeated
    values joined by ';'."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        v = float(value)
        return str(int(v)) if v.is_integer() and abs(v) < 2**53 else repr(v)
    if isinstance(value, (tuple, list)):
        if repeatable and value and all(isinstance(x, (tuple, list, str)) for x in value):
            return ";".join(_text(x, False) for x in value)
        return ",".join(_text(x, False) for x in value)
    return str(value)


def run(command: str, progress: Optional[Callable[[str, int, int], Any]] = None,
        notes: Optional[Callable[[str], Any]] = None, keep_partial: bool = False,
        **options) -> dict:
    """Runs a btfsim command and returns its report (the dict ``btfsim COMMAND --json`` prints).

    Options are the declarations' keys (``memory_budget``, not ``--memory-budget``; positional
    arguments by name too: ``scene``, ``btf``, ``input``…); None leaves an option unset.
    ``progress(stage, done, total)`` is called about every 0.1 s from this thread; returning
    False cancels the run (then Cancelled is raised and nothing is left on disk). ``notes(line)``
    receives the plan, the estimate and warnings as they are known. ``keep_partial`` keeps
    OUTPUT.partial on a cancel so that ``resume=True`` continues it.
    """
    decl = _DECLS.get(command)
    if decl is None:
        raise BtfError(f"unknown command '{command}' (known: {', '.join(_DECLS)})")
    by_name = {o["name"]: o for o in decl["options"]}
    pairs = []
    for k, v in options.items():
        if v is None:
            continue
        o = by_name.get(k)
        pairs.append((k, _text(v, bool(o and o["repeatable"]))))
    return _core.run_request(command, pairs, progress, notes, keep_partial)


def _doc_of(decl: dict) -> str:
    lines = [decl["doc"][:1].upper() + decl["doc"][1:] + ".", "",
             f"Runs ``btfsim {decl['name']}`` (see :func:`run` for progress, notes and cancel) "
             "and returns its report as a dict.", "", "Options:"]
    for o in decl["options"]:
        if o["name"] in ("quiet", "json"):
            continue
        d = o["default"]
        if isinstance(d, list):
            d = d[0] if len(d) == 1 else tuple(d)
            if o["type"] == "integer" and isinstance(d, float) and d.is_integer():
                d = int(d)
        rng = ""
        if o["type"] in ("integer", "number") and (math.isfinite(o["min"]) or math.isfinite(o["max"])):
            rng = f", in {o['min']:g}..{o['max']:g}"
        if o["choices"]:
            rng = ", one of " + "|".join(o["choices"])
        default = "required" if o["required"] else (
            "the scene's" if o["scene_key"] else f"default {d!r}")
        lines.append(f"    {o['name']} ({o['type']}{rng}; {default}): {o['doc']}")
    return "\n".join(lines)


def _make_command(name: str):
    def call(progress=None, notes=None, keep_partial=False, **options):
        return run(name, progress=progress, notes=notes, keep_partial=keep_partial, **options)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = _doc_of(_DECLS[name])
    return call


for _name in _DECLS:
    if _name.isidentifier() and _name not in globals():
        globals()[_name] = _make_command(_name)
        __all__.append(_name)
del _name
