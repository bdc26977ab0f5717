#include <btf/core/error.h>
#include <btf/scene/params.h>

namespace btf {

const char* paramTypeName(ParamType t) {
  switch (t) {
    case ParamType::Float:
      return "number";
    case ParamType::Int:
      return "integer";
    case ParamType::Bool:
      return "boolean";
    case ParamType::Rgb:
      return "RGB triple";
    case ParamType::Vec2:
      return "array of 2 numbers";
    case ParamType::Vec3:
      return "array of 3 numbers";
    case ParamType::Int2:
      return "array of 2 integers";
    case ParamType::String:
      return "string";
    case ParamType::Enum:
      return "string";
    case ParamType::Path:
      return "path string";
  }
  return "?";
}

int paramArity(ParamType t) {
  switch (t) {
    case ParamType::Float:
    case ParamType::Int:
    case ParamType::Bool:
      return 1;
    case ParamType::Vec2:
    case ParamType::Int2:
      return 2;
    case ParamType::Rgb:
    case ParamType::Vec3:
      return 3;
    default:
      return 0;
  }
}

const ParamDecl* TypeDecl::find(const std::string& key) const {
  for (const auto& p : params)
    if (p.name == key) return &p;
  return nullptr;
}

const ParamValue& ParamSet::at(const std::string& k) const {
  auto it = m_values.find(k);
  BTF_CHECK_MSG(it != m_values.end(), "parameter '" + k + "' not declared");
  return it->second;
}
Vec2 ParamSet::v2(const std::string& k) const {
  const auto& n = at(k).num;
  return {float(n.at(0)), float(n.at(1))};
}
Vec3 ParamSet::v3(const std::string& k) const {
  const auto& n = at(k).num;
  return {float(n.at(0)), float(n.at(1)), float(n.at(2))};
}
std::array<int, 2> ParamSet::i2(const std::string& k) const {
  const auto& n = at(k).num;
  return {int(n.at(0)), int(n.at(1))};
}

ParamSet defaultParams(const TypeDecl& decl) {
  ParamSet s;
  for (const auto& p : decl.params) s.set(p.name, ParamValue{p.def, p.defStr});
  return s;
}

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

ParamDecl num(ParamType t, std::string name, std::vector<double> def, double lo, double hi,
              std::string doc, bool loExclusive = false) {
  ParamDecl d;
  d.name = std::move(name);
  d.type = t;
  d.def = std::move(def);
  d.min = lo;
  d.max = hi;
  d.minExclusive = loExclusive;
  d.doc = std::move(doc);
  return d;
}
ParamDecl fl(std::string n, double def, double lo, double hi, std::string doc, bool ex = false) {
  return num(ParamType::Float, std::move(n), {def}, lo, hi, std::move(doc), ex);
}
ParamDecl in(std::string n, int def, int lo, int hi, std::string doc) {
  return num(ParamType::Int, std::move(n), {double(def)}, lo, hi, std::move(doc));
}
ParamDecl bo(std::string n, bool def, std::string doc) {
  return num(ParamType::Bool, std::move(n), {def ? 1.0 : 0.0}, 0, 1, std::move(doc));
}
ParamDecl rgb(std::string n, Vec3 def, double lo, double hi, std::string doc) {
  return num(ParamType::Rgb, std::move(n), {def.x, def.y, def.z}, lo, hi, std::move(doc));
}
ParamDecl v3(std::string n, Vec3 def, double lo, double hi, std::string doc, bool ex = false) {
  return num(ParamType::Vec3, std::move(n), {def.x, def.y, def.z}, lo, hi, std::move(doc), ex);
}
ParamDecl v2(std::string n, Vec2 def, double lo, double hi, std::string doc, bool ex = false) {
  return num(ParamType::Vec2, std::move(n), {def.x, def.y}, lo, hi, std::move(doc), ex);
}
ParamDecl i2(std::string n, std::array<int, 2> def, int lo, int hi, std::string doc) {
  return num(ParamType::Int2, std::move(n), {double(def[0]), double(def[1])}, lo, hi,
             std::move(doc));
}
ParamDecl en(std::string n, std::string def, std::vector<std::string> choices, std::string doc) {
  ParamDecl d;
  d.name = std::move(n);
  d.type = ParamType::Enum;
  d.defStr = std::move(def);
  d.choices = std::move(choices);
  d.doc = std::move(doc);
  return d;
}
ParamDecl pa(std::string n, std::string doc) {
  ParamDecl d;
  d.name = std::move(n);
  d.type = ParamType::Path;
  d.required = true;
  d.doc = std::move(doc);
  return d;
}
ParamDecl hfRes(int def) {
  return i2("resolution", {def, def}, 2, 4096,
            "grid vertices per tile along x and y (the height field is sampled on this grid)");
}
}  // namespace

const std::vector<TypeDecl>& materialTypes() {
  static const std::vector<TypeDecl> types = {
      {"material",
       "lambert",
       "Ideal diffuse reflector: f = albedo / π.",
       {rgb("albedo", {0.8f, 0.8f, 0.8f}, 0, 1, "diffuse albedo ρ per channel")}},
      {"material",
       "blinn_phong",
       "Energy-normalised Blinn-Phong: f = kd/π + ks·(n+8)/(8π)·cos^n θh.",
       {rgb("diffuse", {0.5f, 0.5f, 0.5f}, 0, 1, "diffuse albedo kd"),
        rgb("specular", {0.3f, 0.3f, 0.3f}, 0, 1, "specular weight ks"),
        fl("exponent", 50, 0, 1e5, "Phong exponent n of the half-vector lobe")}},
      {"material",
       "cook_torrance",
       "Torrance-Sparrow / Cook-Torrance microfacet BRDF: f = kd/π + ks·D·G·F / (4 cosθi cosθo), "
       "D Beckmann or GGX, G the separable Smith masking-shadowing of D.",
       {rgb("diffuse", {0, 0, 0}, 0, 1, "diffuse albedo kd"),
        rgb("specular", {1, 1, 1}, 0, 1, "specular weight ks"),
        fl("roughness", 0.3, 0.001, 1, "microfacet slope parameter α (Beckmann rms slope / GGX α)"),
        en("distribution", "ggx", {"beckmann", "ggx"}, "normal distribution D"),
        en("fresnel", "schlick", {"none", "schlick", "conductor", "dielectric"},
           "Fresnel term: none (F = 1), Schlick from f0, conductor from (eta, k), dielectric from "
           "ior"),
        rgb("f0", {0.04f, 0.04f, 0.04f}, 0, 1, "normal-incidence reflectance for Schlick"),
        rgb("eta", {0.2f, 0.92f, 1.1f}, 0.01, 100, "conductor refractive index η (default gold)"),
        rgb("k", {3.9f, 2.45f, 2.14f}, 0, 100, "conductor extinction k (default gold)"),
        fl("ior", 1.5, 1.0, 10, "dielectric index of refraction")}},
      {"material",
       "ward",
       "Ward anisotropic BRDF (1992): f = ρd/π + ρs·exp(−tan²θh (cos²φh/αx² + sin²φh/αy²)) / "
       "(4π αx αy √(cosθi cosθo)); αx along the surface tangent (the projection of +x).",
       {rgb("diffuse", {0.3f, 0.3f, 0.3f}, 0, 1, "diffuse albedo ρd"),
        rgb("specular", {0.2f, 0.2f, 0.2f}, 0, 1, "specular albedo ρs"),
        fl("alpha_x", 0.1, 0.001, 1, "roughness along the tangent", true),
        fl("alpha_y", 0.3, 0.001, 1, "roughness along the bitangent", true)}},
  };
  return types;
}

const std::vector<TypeDecl>& partTypes() {
  static const std::vector<TypeDecl> types = {
      {"part",
       "plane",
       "A flat sheet covering the whole tile at height z.",
       {fl("height", 0, -kInf, kInf, "z of the sheet")}},
      {"part",
       "sine",
       "Height field z = base + amplitude·sin(2π(px·x/Lx + py·y/Ly) + phase).",
       {fl("amplitude", 0.1, 0, kInf, "half peak-to-peak height"),
        i2("periods", {1, 0}, 0, 1024,
           "whole periods across the tile in x and y (integers keep it periodic)"),
        fl("phase", 0, -360, 360, "phase in degrees"), fl("base", 0, -kInf, kInf, "mean height"),
        hfRes(64)}},
      {"part",
       "bumps",
       "Height field of a regular grid of bumps (spherical caps or Gaussians).",
       {i2("count", {4, 4}, 1, 1024, "bumps across the tile in x and y"),
        fl("radius", 0.4, 0, 0.5, "bump radius as a fraction of the cell size", true),
        fl("height", 0.1, 0, kInf, "bump height"),
        en("shape", "cap", {"cap", "gaussian"}, "profile of a bump"),
        fl("base", 0, -kInf, kInf, "height between bumps"), hfRes(96)}},
      {"part",
       "vgrooves",
       "Height field of parallel symmetric V-grooves.",
       {in("count", 4, 1, 1024, "grooves across the tile"),
        fl("depth", 0.2, 0, kInf, "groove depth"),
        en("axis", "y", {"x", "y"}, "grooves run along this axis"),
        fl("base", 0, -kInf, kInf, "height of the ridges"),
        in("subdivisions", 4, 1, 256, "grid cells per groove facet (facets stay exactly planar)")}},
      {"part",
       "noise",
       "Periodic fractional Brownian motion height field (gradient noise octaves).",
       {fl("amplitude", 0.1, 0, kInf, "height scale"),
        in("frequency", 4, 1, 256, "lattice cells across the tile for the first octave"),
        in("octaves", 4, 1, 12, "number of octaves (each doubles the frequency)"),
        fl("gain", 0.5, 0, 1, "amplitude factor per octave"),
        in("seed", 1, 0, 1 << 30, "noise seed"), fl("base", 0, -kInf, kInf, "mean height"),
        hfRes(96)}},
      {"part",
       "image",
       "Height field read from a grey image (OpenImageIO): z = base + height·value.",
       {pa("path", "image file, relative to the scene file"),
        fl("height", 0.1, -kInf, kInf, "height of value 1"),
        fl("base", 0, -kInf, kInf, "height of value 0"),
        i2("resolution", {0, 0}, 0, 4096, "grid vertices per tile; 0 = the image's own size")}},
      {"part",
       "sphere",
       "A sphere (UV tessellation).",
       {v3("center", {0.5f, 0.5f, 0.f}, -kInf, kInf, "centre"),
        fl("radius", 0.25, 0, kInf, "radius", true),
        in("segments", 32, 4, 1024, "segments around the equator")}},
      {"part",
       "box",
       "An axis-aligned box before its transform.",
       {v3("center", {0.5f, 0.5f, 0.1f}, -kInf, kInf, "centre"),
        v3("size", {0.5f, 0.5f, 0.2f}, 0, kInf, "edge lengths", true)}},
      {"part",
       "cylinder",
       "A z-aligned cylinder standing on its base centre (with caps).",
       {v3("center", {0.5f, 0.5f, 0.f}, -kInf, kInf, "centre of the bottom cap"),
        fl("radius", 0.2, 0, kInf, "radius", true), fl("height", 0.3, 0, kInf, "height", true),
        in("segments", 32, 3, 1024, "segments around"), bo("caps", true, "close both ends")}},
      {"part",
       "cone",
       "A z-aligned cone standing on its base centre (with a base cap).",
       {v3("center", {0.5f, 0.5f, 0.f}, -kInf, kInf, "centre of the base"),
        fl("radius", 0.2, 0, kInf, "base radius", true), fl("height", 0.3, 0, kInf, "height", true),
        in("segments", 32, 3, 1024, "segments around")}},
      {"part",
       "torus",
       "A torus around the z axis.",
       {v3("center", {0.5f, 0.5f, 0.f}, -kInf, kInf, "centre"),
        fl("major_radius", 0.3, 0, kInf, "radius of the ring", true),
        fl("minor_radius", 0.08, 0, kInf, "radius of the tube", true),
        i2("segments", {48, 16}, 3, 1024, "segments around the ring and around the tube")}},
      {"part",
       "tube",
       "A periodic swept tube (a thread of a weave): a circle of `radius` swept along a centre "
       "line "
       "that runs across the whole tile along `axis` and undulates in z as "
       "z = height + amplitude·sin(2π·waves·s + phase).",
       {en("axis", "x", {"x", "y"}, "direction the thread runs"),
        fl("offset", 0.25, -kInf, kInf, "position of the centre line across the other axis"),
        fl("height", 0, -kInf, kInf, "mean z of the centre line"),
        fl("radius", 0.1, 0, kInf, "thread radius", true),
        fl("amplitude", 0.05, 0, kInf, "undulation amplitude (over and under)"),
        in("waves", 1, 0, 256, "undulation periods across the tile"),
        fl("phase", 0, -360, 360, "undulation phase in degrees"),
        i2("segments", {64, 12}, 3, 4096, "segments along the tile and around the thread")}},
      {"part",
       "mesh",
       "A triangle or polygon mesh read with OpenMesh (OBJ, PLY, OFF).",
       {pa("path", "mesh file, relative to the scene file"),
        bo("smooth", true, "smooth (vertex) normals; false gives flat facets")}},
      {"part",
       "subdiv",
       "A subdivision surface: a control cage (OBJ/PLY/OFF) refined uniformly by OpenSubdiv.",
       {pa("path", "cage file, relative to the scene file"),
        in("levels", 3, 1, 6, "uniform refinement levels"),
        en("scheme", "catmark", {"catmark", "loop", "bilinear"}, "subdivision scheme")}},
  };
  return types;
}

const TypeDecl& transformDecl() {
  static const TypeDecl d{
      "transform",
      "transform",
      "Applied to a part's geometry as scale, then rotate (x, then y, then z), then translate.",
      {v3("translate", {0, 0, 0}, -kInf, kInf, "translation"),
       v3("rotate", {0, 0, 0}, -360, 360, "rotation in degrees about x, y, z"),
       v3("scale", {1, 1, 1}, 0, kInf, "scale factors", true)}};
  return d;
}

const TypeDecl& arrayDecl() {
  static const TypeDecl d{
      "array",
      "array",
      "Repeats a part on a regular grid inside the tile (after its transform).",
      {i2("count", {1, 1}, 1, 1024, "copies along x and y"),
       v2("spacing", {0, 0}, 0, kInf, "distance between copies; 0 = tile size / count"),
       fl("row_shift", 0, -1, 1,
          "x shift of every odd row as a fraction of the x spacing (bricks)")}};
  return d;
}

const TypeDecl& simulationDecl() {
  static const TypeDecl d{
      "simulation",
      "simulation",
      "Default simulation settings of the scene; the command line overrides each.",
      {i2("texels", {32, 32}, 1, 16384, "texels Nu × Nv over the tile"),
       en("directions", "bonn81", {"bonn81", "ubo151", "grid", "axis-grid"},
          "direction set: grid is cell-centred; axis-grid has the pole and φ = 0°, 90°, 180°, "
          "270° on every ring (φ count a multiple of 4)"),
       i2("grid", {16, 32}, 1, 1024, "θ × φ counts when directions = grid or axis-grid"),
       en("sampling", "adaptive", {"adaptive", "uniform"},
          "adaptive: each texel's footprint integrated with 2×2 samples, refined up to max_spp × "
          "max_spp where they disagree (edges, shadow boundaries); uniform: spp × spp everywhere "
          "(the reference mode)"),
       in("max_spp", 8, 2, 64, "adaptive: finest level, K×K samples per texel (a power of two)"),
       in("spp", 1, 1, 64,
          "uniform: K×K jittered rays per texel (1 = texel centre); ignored when adaptive"),
       en("shadows", "map", {"map", "rays"},
          "self-shadowing: shadow-map test or exact shadow rays"),
       in("seed", 1, 0, 1 << 30, "seed of the jitter"),
       en("method", "network", {"network", "pt"},
          "network: direct light + point-network inter-reflection where the plan calls for it; "
          "pt: every value path traced (docs/gi.md)"),
       en("interreflection", "auto", {"auto", "on", "off"},
          "inter-reflection: decided by the effect planner, or forced"),
       in("bounces", 0, 0, 64, "P, reflections per path (1 = direct only); 0 = from the plan"),
       in("network_voxels", 0, 0, 1024,
          "point-network density, voxels along the longer tile side; 0 = one per texel, at least "
          "64 and at most 128")}};
  return d;
}

const TypeDecl& tileDecl() {
  static const TypeDecl d{"tile",
                          "tile",
                          "The periodic tile of the reference plane z = 0.",
                          {v2("size", {1, 1}, 1e-3, 1e3,
                              "periods Lx, Ly (1e-3..1e3: the tracer's offsets and float "
                              "positions are sized for it)")}};
  return d;
}

const TypeDecl* findType(const std::vector<TypeDecl>& types, const std::string& name) {
  for (const auto& t : types)
    if (t.name == name) return &t;
  return nullptr;
}

std::string typeNames(const std::vector<TypeDecl>& types) {
  std::string s;
  for (const auto& t : types) s += (s.empty() ? "" : ", ") + t.name;
  return s;
}

}  // namespace btf
