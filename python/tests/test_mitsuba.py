"""The Mitsuba 3 plugin (btfstudio.mitsuba): a plane under an orthographic camera and a
directional light renders btfsim's slice within 1 % per pixel in the scalar and the LLVM
variants, tiling repeats the tile, and nothing is NaN at grazing directions. Runs in the project's
venv (scripts/python-venv.sh), where Mitsuba 3 is installed."""

import os

import numpy as np
import pytest

if os.environ.get("BTF_REQUIRE_MITSUBA"):  # ctest: the venv must have it
    import mitsuba as mi
else:
    mi = pytest.importorskip("mitsuba", reason="run by ctest in BUILD/venv (scripts/python-venv.sh)")
import drjit as dr  # noqa: E402

import btfstudio  # noqa: E402
import btfstudio.mitsuba as bm  # noqa: E402

VARIANTS = ["scalar_rgb", "llvm_ad_rgb"]


def use(variant):
    mi.set_variant(variant)
    bm.register()


def unit(theta, phi):
    t, p = np.radians(theta), np.radians(phi)
    return [float(np.sin(t) * np.cos(p)), float(np.sin(t) * np.sin(p)), float(np.cos(t))]


def plane_render(path, light, width, height, tiling="1,1", spp=1):
    """The rectangle [-1, 1] x [-h/w, h/w] (uv over it) seen straight down by an orthographic
    camera whose film covers it exactly, one sample at each pixel centre, lit by a directional light of unit
    irradiance from `light` (θ, φ): each pixel is aBRDF(light, normal view) · cos θ_light."""
    d = unit(*light)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0],
                                                       up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "stratified", "sample_count": spp, "jitter": False},
        },
        "plane": {"type": "rectangle",
                  "to_world": mi.ScalarTransform4f().scale([1, height / width, 1]),
                  "bsdf": {"type": "btf", "filename": str(path), "tiling": tiling}},
        "light": {"type": "directional", "direction": [-d[0], -d[1], -d[2]],
                  "irradiance": {"type": "rgb", "value": 1.0}},
    })
    return np.array(mi.render(scene))


@pytest.fixture(scope="module")
def square(tmp_path_factory):
    """A square brick tile (the plane's camera is square): 8 x 8 texels, 4 x 8 directions."""
    from conftest import btfsim, scene
    p = tmp_path_factory.mktemp("mi") / "brick8.btf"
    btfsim("simulate", scene("brick"), "-o", p, "--texels", "8", "--dirs", "4x8", "--spp", "2",
           "-q")
    return p


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("light", [(33.75, 22.5), (56.25, 202.5), (45, 0), (70, 300), (5, 90)])
def test_a_plane_renders_the_slice_within_one_percent_per_pixel(square, variant, light):
    use(variant)
    b = btfstudio.open(square)
    img = plane_render(square, light, b.nu, b.nv)
    ref = b.slice(view=(0, 0), light=light) * np.cos(np.radians(light[0]))
    assert img.shape == ref.shape
    assert np.all(np.isfinite(img))
    err = np.abs(img - ref) / np.maximum(ref, 1e-3 * ref.max())
    assert err.max() <= 0.01, (variant, light, err.max())


@pytest.mark.parametrize("variant", VARIANTS)
def test_tiling_repeats_the_tile(square, variant):
    use(variant)
    b = btfstudio.open(square)
    img = plane_render(square, (45, 135), 3 * b.nu, 2 * b.nv, tiling="3,2")
    ref = np.tile(b.slice(view=(0, 0), light=(45, 135)), (2, 3, 1)) * np.cos(np.radians(45))
    err = np.abs(img - ref) / np.maximum(ref, 1e-3 * ref.max())
    assert err.max() <= 0.01


@pytest.mark.parametrize("variant", VARIANTS)
def test_grazing_and_below_horizon_directions_are_finite_and_zero_below(square, variant):
    use(variant)
    bsdf = mi.load_dict({"type": "btf", "filename": str(square)})
    ctx = mi.BSDFContext()
    thetas = [0.0, 30.0, 80.0, 89.0, 89.99, 90.0, 90.5, 120.0, 180.0]
    pairs = [(a, c) for a in thetas for c in thetas]
    for (ti, to) in pairs:
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.uv = mi.Point2f(0.3, 0.7)
        si.wi = mi.Vector3f(*unit(ti, 40.0))
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        wo = mi.Vector3f(*unit(to, 200.0))
        f = np.array(bsdf.eval(ctx, si, wo)).ravel()
        p = np.array(bsdf.pdf(ctx, si, wo)).ravel()
        assert np.all(np.isfinite(f)) and np.all(f >= 0) and np.all(np.isfinite(p)), (ti, to)
        if ti > 90 or to > 90:
            assert np.all(f == 0), (ti, to, f)
        bs, w = bsdf.sample(ctx, si, 0.5, mi.Point2f(0.99, 0.3))
        w = np.array(w).ravel()
        assert np.all(np.isfinite(w)) and np.all(w >= 0), (ti, w)
        if ti > 90:
            assert np.all(w == 0)


def test_a_path_traced_sphere_is_finite(square):
    use("llvm_ad_rgb")
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, -4, 2], target=[0, 0, 0],
                                                              up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": 48, "height": 32},
                   "sampler": {"type": "independent", "sample_count": 4}},
        "sphere": {"type": "sphere", "bsdf": {"type": "btf", "filename": str(square),
                                              "tiling": 4}},
        "floor": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate([0, 0, -1])
                  @ mi.ScalarTransform4f().scale(4),
                  "bsdf": {"type": "btf", "filename": str(square), "tiling": "8,8"}},
        "sun": {"type": "directional", "direction": [0.3, 0.5, -1], "irradiance": 3.0},
        "sky": {"type": "constant", "radiance": 0.2},
    })
    img = np.array(mi.render(scene))
    assert np.all(np.isfinite(img)) and img.max() > 0


def test_bad_properties_are_refused_with_the_reason(square, tmp_path):
    use("scalar_rgb")
    with pytest.raises(Exception, match="filename"):
        mi.load_dict({"type": "btf"})
    with pytest.raises(Exception, match="tiling"):
        mi.load_dict({"type": "btf", "filename": str(square), "tiling": "0,1"})
    with pytest.raises(Exception, match="level 7"):
        mi.load_dict({"type": "btf", "filename": str(square), "level": 7})
    with pytest.raises(Exception, match="sampling must be"):
        mi.load_dict({"type": "btf", "filename": str(square), "sampling": "uniform"})
    with pytest.raises(Exception, match="grid must be within"):
        mi.load_dict({"type": "btf", "filename": str(square), "grid": 1})
    with pytest.raises(Exception, match="cosine_fraction"):
        mi.load_dict({"type": "btf", "filename": str(square), "cosine_fraction": 0.0})
    with pytest.raises(Exception, match="BTF not found"):
        mi.load_dict({"type": "btf", "filename": str(tmp_path / "none.btf")})


# --- importance sampling from the tile average -------------------------------------------------

def wavefront(n, view_theta, rng):
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.uv = mi.Point2f(rng.random(n), rng.random(n))
    v = unit(view_theta, 57.0)
    si.wi = mi.Vector3f(*[mi.Float(np.full(n, x)) for x in v])
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    return si


@pytest.mark.parametrize("view_theta", [0.0, 50.0, 80.0])
def test_importance_sampling_draws_what_its_pdf_says(square, view_theta, tmp_path, monkeypatch):
    """Mitsuba's own chi-square test of sample() against pdf(); and the same test rejects the
    importance sampler's directions judged by the cosine pdf (it can fail)."""
    monkeypatch.chdir(tmp_path)  # a failing test writes chi2_data.py into the working folder
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain
    use("llvm_ad_rgb")
    wi = unit(view_theta, 40.0)
    prop = f'<string name="filename" value="{square}"/>'
    sample_is, pdf_is = BSDFAdapter("btf", prop, wi=wi)
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_is, pdf_func=pdf_is,
                         sample_dim=3, ires=16)
    assert chi2.run(), chi2.messages
    _, pdf_cos = BSDFAdapter("btf", prop + '<string name="sampling" value="cosine"/>', wi=wi)
    wrong = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_is, pdf_func=pdf_cos,
                          sample_dim=3, ires=16)
    assert not wrong.run()


def test_importance_sampling_is_unbiased_normalised_and_lowers_the_variance(square):
    use("llvm_ad_rgb")
    ctx = mi.BSDFContext()
    n = 200_000
    cos = mi.load_dict({"type": "btf", "filename": str(square), "sampling": "cosine"})
    imp = mi.load_dict({"type": "btf", "filename": str(square)})
    for theta in (0.0, 40.0, 70.0):
        est = {}
        for name, b in (("cosine", cos), ("importance", imp)):
            rng = np.random.default_rng(7)
            si = wavefront(n, theta, rng)
            bs, w = b.sample(ctx, si, mi.Float(rng.random(n)), mi.Point2f(rng.random(n), rng.random(n)))
            w = np.array(w)
            assert np.all(np.isfinite(w)) and np.all(w >= 0)
            # sample()'s pdf is pdf() at the direction drawn, and its weight eval / pdf.
            p = np.array(b.pdf(ctx, si, bs.wo))
            assert np.allclose(np.array(bs.pdf), p, rtol=1e-6)
            f = np.array(b.eval(ctx, si, bs.wo))
            assert np.allclose(w, f / np.maximum(p, 1e-30), rtol=1e-5, atol=1e-7)
            # ∫ pdf dω = 1 (uniform hemisphere quadrature).
            u = mi.warp.square_to_uniform_hemisphere(mi.Point2f(rng.random(n), rng.random(n)))
            assert abs(np.mean(np.array(b.pdf(ctx, si, u))) * 2 * np.pi - 1) < 0.01
            est[name] = (w.mean(axis=1), w.mean(axis=0).var())  # the luminance's variance
        # The same albedo (both unbiased, 200 k samples each) at a lower variance.
        assert np.allclose(est["importance"][0], est["cosine"][0], rtol=0.01), (theta, est)
        assert est["importance"][1] < 0.8 * est["cosine"][1], (theta, est)


# --- btfsim export --format rgl-bsdf, read by Mitsuba's own `measured` BSDF ------------------

FLAT = ('{"btfscene": 1, "materials": {"m": {"type": "lambert", "albedo": [0.6, 0.4, 0.2]}}, '
        '"parts": [{"type": "plane", "material": "m"}]}')


def pairs20():
    rng = np.random.default_rng(3)
    p = [((0, 0), (45, 0)), ((30, 90), (30, 270)), ((60, 10), (20, 200)), ((75, 0), (75, 180)),
         ((80, 45), (10, 0)), ((85, 120), (40, 300)), ((88, 10), (60, 200)), ((20, 0), (87, 90))]
    while len(p) < 20:
        p.append(((float(rng.uniform(0, 85)), float(rng.uniform(0, 360))),
                  (float(rng.uniform(0, 85)), float(rng.uniform(0, 360)))))
    return p


def measured_eval(m, view, light):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*unit(*view))
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    return np.array(m.eval(mi.BSDFContext(), si, mi.Vector3f(*unit(*light))))


@pytest.fixture(scope="module")
def rgl(tmp_path_factory):
    from conftest import btfsim, scene
    d = tmp_path_factory.mktemp("rgl")
    (d / "flat.json").write_text(FLAT)
    out = {}
    for name, src, texels in (("flat", d / "flat.json", "4"), ("brick", scene("brick"), "16")):
        btf = d / f"{name}.btf"
        btfsim("simulate", src, "-o", btf, "--texels", texels, "--dirs", "8x16", "--spp", "2", "-q")
        bsdf = d / f"{name}.bsdf"
        btfsim("export", btf, "--format", "rgl-bsdf", "-o", bsdf, "-q")
        out[name] = (btf, bsdf)
    return out


def test_the_rgl_export_of_a_flat_lambertian_tile_is_rho_over_pi(rgl):
    use("scalar_rgb")
    m = mi.load_dict({"type": "measured", "filename": str(rgl["flat"][1])})
    rho = np.array([0.6, 0.4, 0.2])
    for view, light in pairs20():
        want = rho / np.pi * np.cos(np.radians(light[0]))
        got = measured_eval(m, view, light)
        assert np.all(np.abs(got - want) <= 0.02 * want.max()), (view, light, got, want)


def test_the_rgl_export_of_brick_reproduces_the_tile_average_within_three_percent(rgl):
    use("scalar_rgb")
    btf, bsdf = rgl["brick"]
    b = btfstudio.open(btf)
    m = mi.load_dict({"type": "measured", "filename": str(bsdf)})
    centres = np.array([[(i + .5) / b.nu, (j + .5) / b.nv] for j in range(b.nv)
                        for i in range(b.nu)])
    worst = 0
    for view, light in pairs20():
        v, l = np.array(unit(*view)), np.array(unit(*light))
        want = b.values(centres, np.tile(l, (len(centres), 1)),
                        np.tile(v, (len(centres), 1))).mean(0) * l[2]
        got = measured_eval(m, view, light)
        worst = max(worst, np.abs(got - want).max() / want.max())
    assert worst <= 0.03, worst


@pytest.mark.parametrize("variant", VARIANTS)
def test_the_rgl_export_renders_nan_free_at_grazing_directions(rgl, variant):
    use(variant)
    m = mi.load_dict({"type": "measured", "filename": str(rgl["brick"][1])})
    ctx = mi.BSDFContext()
    for ti in (0.0, 45.0, 85.0, 89.0, 89.9):
        for to in (0.0, 60.0, 88.0, 89.9, 90.0, 100.0):
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wi = mi.Vector3f(*unit(ti, 30.0))
            si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
            f = np.array(m.eval(ctx, si, mi.Vector3f(*unit(to, 250.0)))).ravel()
            p = np.array(m.pdf(ctx, si, mi.Vector3f(*unit(to, 250.0)))).ravel()
            assert np.all(np.isfinite(f)) and np.all(f >= 0) and np.all(np.isfinite(p))
            _, w = m.sample(ctx, si, 0.5, mi.Point2f(0.3, 0.8))
            assert np.all(np.isfinite(np.array(w)))
