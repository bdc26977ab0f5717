// The declarations of every command (request.h): names, types, ranges, defaults and docs. The
// CLI, docs/cli.md, the studio's forms and validation all read these tables.
#include <btf/ops/request.h>

#include <limits>

namespace btf::ops {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

ParamDecl num(ParamType t, const std::string& n, double def, double lo, double hi,
              const std::string& doc) {
  ParamDecl d;
  d.name = n;
  d.type = t;
  d.def = {def};
  d.min = lo;
  d.max = hi;
  d.doc = doc;
  return d;
}
ParamDecl in(const std::string& n, double def, double lo, double hi, const std::string& doc) {
  return num(ParamType::Int, n, def, lo, hi, doc);
}
ParamDecl fl(const std::string& n, double def, double lo, double hi, const std::string& doc) {
  return num(ParamType::Float, n, def, lo, hi, doc);
}
ParamDecl flag(const std::string& n, const std::string& doc) {
  return num(ParamType::Bool, n, 0, 0, 1, doc);
}
ParamDecl str(const std::string& n, const std::string& def, const std::string& doc,
              ParamType t = ParamType::String) {
  ParamDecl d;
  d.name = n;
  d.type = t;
  d.defStr = def;
  d.doc = doc;
  return d;
}
ParamDecl path(const std::string& n, const std::string& doc, bool required = true) {
  ParamDecl d = str(n, "", doc, ParamType::Path);
  d.required = required;
  return d;
}
ParamDecl en(const std::string& n, const std::string& def, std::vector<std::string> choices,
             const std::string& doc) {
  ParamDecl d = str(n, def, doc, ParamType::Enum);
  d.choices = std::move(choices);
  return d;
}

ParamDecl repeatable(ParamDecl d) {
  d.repeatable = true;
  return d;
}
ParamDecl excl(ParamDecl d) {
  d.minExclusive = true;
  return d;
}

// The texel level of a multi-resolution BTF (docs/mip.md).
ParamDecl levelOption() {
  return in("level", 0, 0, 30,
            "texel level: 0 = the simulated texels, k = 2^k×2^k box averages (a --mip .cbtf "
            "decodes its own; other files are box-filtered in memory)");
}

using Opts = std::vector<ParamDecl>;
void append(Opts& a, const Opts& b) {
  a.insert(a.end(), b.begin(), b.end());
}

// Scene-backed simulation options: absent from a request unless given (the scene decides).
Opts sceneOptions() {
  return {
      str("dirs", "",
          "direction set: bonn81, ubo151, a θ×φ grid like 16x32, or with azimuths on the axes like "
          "16x32a (scene)"),
      str("texels", "", "texels: N or NUxNV (scene)"),
      en("sampling", "adaptive", {"adaptive", "uniform"},
         "adaptive: 2×2 samples per texel refined up to --max-spp where they disagree; uniform: "
         "K×K (--spp; giving --spp alone selects it) (scene)"),
      in("max_spp", 8, 2, 64,
         "adaptive: finest level, K×K samples per texel (power of two) (scene)"),
      in("spp", 1, 1, 64, "uniform: K×K jittered rays per texel (scene)"),
      en("shadows", "map", {"map", "rays"}, "self-shadowing: shadow map or exact rays (scene)")};
}
const std::set<std::string> kSceneKeys = {"dirs",     "texels",  "spp",  "shadows",
                                          "sampling", "max_spp", "seed", "method"};

Opts effectOptions() {
  return {
      en("method", "network", {"network", "pt"},
         "network (direct + point-network GI) or pt (path traced) (scene)"),
      en("visibility", "auto", {"auto", "exact", "sampled"},
         "direct light: exact (flat faces by area, no samples; smooth faces sampled uniformly), "
         "sampled, or auto (exact on a faceted scene when adaptive sampling is asked for)"),
      en("self_shadowing", "auto", {"auto", "on", "off"}, "self-shadowing: planner or forced"),
      en("interreflection", "auto", {"auto", "on", "off"}, "inter-reflection: planner or forced"),
      in("bounces", 0, 0, 64, "P: reflections per path (1 = direct only; 0 = from the plan)"),
      fl("epsilon", 0.01, 1e-6, 0.5, "planner: energy fraction below which an order is dropped"),
      flag("edge_cells",
           "adaptive sampling: also split every cell whose footprint holds a geometric edge, at "
           "the 4×4 level and in the shared refinement of the faces' areas (slivers every "
           "sample missed; slower; cells a shadow edge may cross always split)"),
      excl(fl("tolerance", 0.01, 0, 1,
              "adaptive sampling: a value refines while its estimated error exceeds this "
              "fraction of max(value, floor)")),
      en("tail", "auto", {"auto", "add", "drop"},
         "inter-reflection orders past P: add them as the geometric series of the last two "
         "orders' measured ratio (auto: when the plan chose P >= 3) or drop them"),
      en("glossy_indirect", "auto", {"auto", "on", "off"},
         "glossy lobes reflect the indirect light at the texels"),
      en("colour", "auto", {"auto", "on", "off"}, "RGB (on) or one channel for grey scenes (off)"),
      en("vmf", "auto", {"auto", "on", "off"}, "store the visibility map"),
      fl("grazing_rays", 70, 0, 90,
         "shadow maps: lights at θi ≥ this many degrees use exact shadow rays (90 = none)"),
      in("network_voxels", 0, 0, 1024,
         "network density, voxels per side (0 = one per texel, at least 64, at most 128)"),
      in("links", 16, 1, 256, "network links per point"),
      in("gather", 4, 1, 16, "N1: network points per direct hit"),
      in("gather_occlusion", 16, 0, 1024,
         "rays per gathered hit measuring its own occluded fraction; the network's irradiance "
         "is scaled by it over the points' (0 = off)"),
      en("reciprocal_gather", "on", {"on", "off"},
         "scale the network's gathered light per (view, light) so that its tile average obeys "
         "reciprocity: the mean of the (v, l) and (l, v) estimates (docs/gi.md)"),
      in("paths", 16, 1, 4096, "--method pt: paths per texel sample"),
  };
}

Opts codecOptions(bool withName) {
  Opts o;
  if (withName)
    // The default is the codec that wins at 1:300 on the resource scenes against converged
    // references (docs/performance.md, "The neural codec against the factorisation codecs").
    o.push_back(en("codec", "tensor", {"nmf", "svd", "perview", "lpca", "tensor", "neural"},
                   "tensor (clustered Tucker; the default: the most accurate at 1:300 measured), "
                   "nmf (per-texel NMF + PCA), svd, perview, lpca or neural (latent texels + a "
                   "shared decoder network)"));
  append(o, {
                en("colour_model", "ycc", {"ycc", "rgb"},
                   "rgb or ycc (luminance + two chroma channels)"),
                in("components", 0, 0, 4096,
                   "PCA components; neural: latent values per texel (0 = from the target)"),
                fl("target_rmse", 0, 0, 1, "relative RMSE target, e.g. 0.05 (0 = the default 5 %)"),
                fl("target_ratio", 0, 0, 1e6, "compression ratio target, e.g. 300 (0 = none)"),
                excl(fl("beta", 0.995, 0, 1, "nmf: β of the per-texel rank rule (eq. 3.21)")),
                en("beta_mode", "energy", {"energy", "singular"},
                   "nmf: energy (Σσ²) or singular (Σσ, the thesis)"),
                en("solver", "hals", {"hals", "mu"},
                   "nmf: hals or mu (Lee-Seung multiplicative updates)"),
                in("max_rank", 8, 1, 64, "nmf: largest per-texel rank"),
                in("nmf_iterations", 60, 1, 10000, "nmf: iterations per texel at most"),
                in("train_texels", 256, 1, 1 << 20,
                   "svd/perview/lpca/tensor: training texels (tensor: at least 32 per cluster)"),
                in("clusters", 0, 0, 4096,
                   "lpca, tensor: k-means clusters (0 = lpca 8, tensor √(texels/2))"),
                flag("halfway",
                     "tensor: factorise each view's light slice in half-vector coordinates "
                     "(docs/compression.md)"),
                in("hidden", 32, 4, 256, "neural: width of the decoder's hidden layers"),
                in("hidden_layers", 2, 1, 8, "neural: hidden layers of the decoder"),
                in("neural_steps", 4000, 1, 1000000,
                   "neural: Adam steps of 4096 samples training the decoder"),
                fl("learning_rate", 2e-2, 1e-6, 0.5, "neural: Adam's initial learning rate"),
                en("encoding", "fourier", {"fourier", "halfdiff", "raw"},
                   "neural: the decoder's direction input: halfdiff (both directions, the half "
                   "vector and the difference vector), fourier (those and their sines and "
                   "cosines) or raw (both directions)"),
                flag("f32", "store float32 arrays instead of float16"),
            });
  return o;
}

std::vector<CommandDecl> build() {
  std::vector<CommandDecl> cs;
  {
    CommandDecl c{"simulate",
                  "simulate a raw BTF into a store file (or, with --compress, "
                  "straight into a codec)",
                  {},
                  {"scene"},
                  kSceneKeys};
    c.options = {path("scene", "scene file (JSON)"),
                 path("output", "output: .btf store, or .cbtf with --compress (atomic)")};
    append(c.options, sceneOptions());
    append(c.options,
           {fl("bias", 1, 0, 1000, "shadow-map bias scale"),
            in("seed", 1, 0, 1 << 30, "jitter seed (scene)"),
            str("memory_budget", "4G", "memory budget, e.g. 4G, 512M"),
            in("chunk_texels", 0, 0, 1 << 30,
               "at most this many texels per chunk (resume granularity; 0 = from the budget)")});
    append(c.options, effectOptions());
    append(c.options,
           {str("compress", "",
                "compress while simulating with this codec (nmf, svd, perview, lpca, tensor, neural); "
                "the output is a .cbtf and no raw BTF is written")});
    append(c.options, codecOptions(false));
    append(c.options,
           {flag("mip",
                 "with --compress: a pyramid of texel levels (docs/mip.md); level 0 goes "
                 "through the temporary store OUTPUT.level0.btf, removed once it is written"),
            flag("resume", "continue an interrupted run from OUTPUT.partial")});
    cs.push_back(c);
  }
  {
    CommandDecl c{"compress", "compress a raw BTF store into a .cbtf", {}, {"input"}, {}};
    c.options = {path("input", "raw BTF store"),
                 path("output", "compressed file (.cbtf, written atomically)")};
    append(c.options, codecOptions(true));
    append(c.options, {str("memory_budget", "8G", "memory budget, e.g. 8G"),
                       flag("compare", "also measure the error against the input"),
                       flag("mip",
                            "a pyramid: every texel level (2×2 box averages down to 1×1) "
                            "coded together, each level's error measured (docs/mip.md)")});
    cs.push_back(c);
  }
  {
    CommandDecl c{"compare", "error between two BTFs (raw or compressed)", {}, {"a", "b"}, {}};
    c.options = {path("a", "reference BTF (.btf or .cbtf)"),
                 path("b",
                      "BTF to measure (same texels; another direction set is evaluated at A's "
                      "directions: continuous for neural, else interpolated)"),
                 str("maps", "", "folder for per-texel and per-direction error maps"),
                 str("noise", "",
                     "a second, independent simulation of A (another --seed): reports A's own "
                     "noise floor, RMS(A − NOISE)/√2, and B's error in excess of it"),
                 in("worst", 10, 0, 1000, "how many worst texels and directions to list"),
                 levelOption(),
                 str("memory_budget", "8G", "memory budget of built levels")};
    cs.push_back(c);
  }
  {
    CommandDecl c{"export",
                  "export a BTF to the Bonn UBO2003/UBO2014, MERL or RGL measured-BSDF formats",
                  {},
                  {"input"},
                  {}};
    c.options = {
        path("input", "BTF (.btf or .cbtf)"),
        en("format", "ubo2014", {"ubo2003", "ubo2014", "merl", "rgl-bsdf"},
           "export format (rgl-bsdf: Mitsuba 3's and pbrt-v4's measured BSDF)"),
        path("output", "folder (ubo2003), .zip (ubo2003 --zip) or file"),
        in("components", 0, 0, 4096, "ubo2014: components per channel (0 = from --target-rmse)"),
        fl("target_rmse", 0.01, 1e-4, 0.5,
           "ubo2014: relative RMSE the export may add to its input"),
        in("phi_samples", 16, 1, 1024, "merl: half-vector azimuths averaged per bin"),
        in("resolution", 48, 4, 256, "rgl-bsdf: half-vector grid per side (per view direction)"),
        en("image_format", "exr", {"exr", "png", "jpg"},
           "ubo2003: linear float EXR, or 8-bit sRGB PNG / JPEG (scaled by --scale)"),
        flag("zip", "ubo2003: one .zip archive instead of a folder (what btf-extractor opens)"),
        fl("scale", 0, 0, 1e12,
           "ubo2003 png/jpg: aBRDF × scale maps to [0, 1] before sRGB (0 = 1 / the peak value)"),
        levelOption(),
        str("memory_budget", "8G", "memory budget of built levels")};
    c.options[1].required = true;
    cs.push_back(c);
  }
  {
    CommandDecl c{"plan",
                  "print the effect plan of a scene with reasons and savings",
                  {},
                  {"scene"},
                  kSceneKeys};
    c.options = {path("scene", "scene file")};
    append(c.options, sceneOptions());
    append(c.options, effectOptions());
    cs.push_back(c);
  }
  {
    CommandDecl c{"bench",
                  "benchmark the simulator (compute only, nothing written)",
                  {},
                  {"scene"},
                  {"method"}};
    c.options = {path("scene", "scene file"),
                 str("texels", "64", "texels"),
                 str("dirs", "16x32", "direction set"),
                 in("spp", 1, 1, 64, "uniform: K (giving it alone selects uniform sampling)"),
                 en("sampling", "adaptive", {"adaptive", "uniform"},
                    "adaptive (refined where samples disagree) or uniform K×K"),
                 in("max_spp", 8, 2, 64, "adaptive: finest level, K×K samples per texel"),
                 str("shadows", "map,rays", "comma-separated shadow modes to measure"),
                 in("repeat", 3, 1, 1000, "runs per mode (the median is reported)")};
    append(c.options, effectOptions());
    cs.push_back(c);
  }
  {
    CommandDecl c{
        "study", "accuracy vs time: sweep the knobs against a path tracer", {}, {"scene"}, {}};
    c.options = {
        path("scene", "scene file"),
        path("output", "output folder (study.csv, study.md, study.svg)"),
        str("texels", "32", "texels of every run"),
        str("method", "network", "methods: network, pt (comma-separated; first = base)"),
        str("paths", "1", "pt: paths per texel sample"),
        str("dirs", "bonn81,8x16,16x32", "direction sets (first = base)"),
        str("spp", "0,1,2", "K values (0 = adaptive sampling, the default; first = base)"),
        str("shadows", "map,rays", "shadow modes: map, rays"),
        str("network_voxels", "0,16,64", "network densities (0 = one per texel)"),
        str("gather", "4,1,8", "N1 values"),
        str("links", "16,8,32", "links per network point"),
        str("bounces", "3,1,2,4",
            "path lengths P (1 = direct only; 0 = the planner's own, as simulate by default)"),
        flag("grid", "full product of the lists instead of one knob at a time"),
        in("reference_spp", 256, 8, 4096, "reference paths per axis per probe pair"),
        in("image_spp", 4, 1, 64, "K of the full images compared per configuration"),
        in("image_paths", 8, 1, 4096, "reference paths per texel sample of the full images"),
        str("codecs", "", "compression knobs: codecs to compare on the base configuration's BTF"),
        str("betas", "0.995", "nmf β values (comma-separated)"),
        str("components", "0", "component counts (0 = from the target)"),
        fl("target_ratio", 0, 0, 1e6, "codec target ratio (with --codecs)"),
        fl("target_rmse", 0, 0, 1, "codec target relative RMSE"),
        en("colour_model", "ycc", {"ycc", "rgb"}, "rgb or ycc"),
        flag("mip",
             "with --codecs: each codec's texel pyramid too (size, time, error per level; "
             "docs/mip.md)")};
    cs.push_back(c);
  }
  {
    CommandDecl c{
        "brdf", "texel-averaged aBRDF at direction pairs, without a BTF", {}, {"scene"}, {}};
    c.options = {path("scene", "scene file"),
                 repeatable(str("pair", "", "θi,φi,θo,φo in degrees; several separated by ';'")),
                 str("pairs", "", "CSV file of θi,φi,θo,φo lines"),
                 in("spp", 64, 1, 4096, "samples per axis over the tile (N×N rays per pair)"),
                 en("method", "pt", {"pt", "direct"}, "pt (path traced, every effect) or direct"),
                 in("bounces", 0, 0, 1024, "pt: reflections per path (0 = unbounded)"),
                 in("paths", 1, 1, 65536, "pt: paths per sample position")};
    cs.push_back(c);
  }
  {
    CommandDecl c{"slice",
                  "an image of a BTF: spatial (view, light) or a hemisphere of views",
                  {},
                  {"btf"},
                  {}};
    c.options = {path("btf", "BTF (.btf or .cbtf)"),
                 path("output", "image file: .exr (linear, with metadata) or .png (sRGB)"),
                 str("view", "", "θ,φ of the view (degrees): spatial image"),
                 str("light", "", "θ,φ of the light (degrees)"),
                 str("texel", "", "u,v or avg: hemisphere image of aBRDF over views"),
                 fl("exposure", 1, 1e-6, 1e6, "PNG: multiplies π·aBRDF before the sRGB curve"),
                 in("size", 256, 8, 8192, "hemisphere image size in pixels"),
                 levelOption(),
                 str("memory_budget", "8G", "memory budget of built levels")};
    c.options[3].required = true;
    cs.push_back(c);
  }
  {
    CommandDecl c{"render",
                  "render a BTF on an object: flat, mapped (silhouettes through the visibility "
                  "map) or exact (the micro-geometry itself, path traced)",
                  {},
                  {"input"},
                  {}};
    c.options = {
        path("input", "BTF (.btf or .cbtf); a scene (.json) renders --mode exact only"),
        path("output",
             "image: .exr (linear RGB + coverage alpha) or .png (sRGB); --mode all: a .png "
             "side by side (exact | mapped | flat | |mapped - exact|) and STEM.MODE.exr"),
        en("mode", "mapped", {"flat", "mapped", "exact", "all"}, "what to render"),
        str("object", "sphere",
            "plane, sphere, cylinder, section, hills, vase, cushion, chair, or a mesh file "
            "(.obj, .ply, .off) with texture coordinates"),
        in("level", 3, 0, 6, "refinement levels of the cage objects (OpenSubdiv)"),
        str("size", "256", "image size: N or WxH pixels"),
        in("spp", 4, 1, 65536, "samples per pixel"),
        str("camera", "35,-90", "θ,φ of the camera seen from the object (degrees)"),
        en("projection", "ortho", {"ortho", "perspective"}, "camera projection"),
        fl("fov", 35, 1, 170, "perspective: vertical field of view (degrees)"),
        excl(fl("zoom", 1, 0, 1000, "magnification")),
        str("light", "45,-30", "θ,φ toward the directional light (degrees)"),
        fl("irradiance", 1, 0, 1e9, "light's irradiance on a surface facing it"),
        fl("environment", 0, 0, 1e9,
           "radiance of a constant sky all around (0 = none; flat and mapped ignore the "
           "object's own occlusion of it)"),
        excl(fl("tiling", 4, 0, 1e6, "tiles per unit of texture coordinates")),
        excl(fl("relief_scale", 1, 0, 1000,
                "multiplies the relief's height on the object (1 = the tile's own)")),
        in("bounces", 0, 0, 256, "exact: reflections per path (0 = unbounded, Russian roulette)"),
        in("seed", 1, 0, 1 << 30, "sample seed"),
        fl("exposure", 1, 1e-6, 1e6, "PNG: multiplies the radiance before the sRGB curve"),
        str("reference", "", "an exact render (.exr with coverage) to measure the error against"),
        str("vmf", "",
            "a raw store of the same scene whose visibility map (full precision) replaces the "
            "8-bit one a .cbtf carries, or supplies one to a .cbtf written before files "
            "carried theirs"),
        str("memory_budget", "8G", "memory budget (BTF values, exact triangles), e.g. 8G"),
        en("filter", "mip", {"mip", "point"},
           "flat and mapped: mip = each sample's texel level from its footprint (ray "
           "differentials), trilinear, anisotropic taps; point = level 0 only (docs/mip.md)"),
        in("mip_level", -1, -1, 30,
           "every lookup (and the visibility map) at this texel level "
           "(-1 = from the footprint)"),
        in("max_aniso", 8, 0, 64,
           "taps along an elongated footprint's long axis (0 = one tap, the long axis sets the "
           "level: the studio's GPU rule)"),
        flag("show_level",
             "draw the texel level each pixel uses in false colour (0 blue, 1 "
             "cyan, 2 green, 3 yellow, 4 red, 5+ magenta)")};
    cs.push_back(c);
  }
  {
    CommandDecl c{"info",
                  "print a BTF's header (raw or compressed) and verify every checksum",
                  {},
                  {"btf"},
                  {}};
    c.options = {path("btf", "BTF (.btf or .cbtf)"),
                 flag("bench_decoder",
                      "compressed: time the CPU decoder on one thread (random values and whole "
                      "texels)")};
    cs.push_back(c);
  }
  for (auto& c : cs)
    append(c.options, {in("threads", 0, 0, 4096, "worker threads (0 = every core)"),
                       flag("quiet", "no progress bars or notes on stderr"),
                       flag("json", "print the report as JSON on stdout")});
  return cs;
}

}  // namespace

const std::vector<CommandDecl>& commands() {
  static const std::vector<CommandDecl> cs = build();
  return cs;
}

}  // namespace btf::ops
