#include <btf/core/error.h>
#include <btf/core/input_file.h>
#include <btf/core/json_limits.h>
#include <btf/scene/scene.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

namespace btf {

using json = nlohmann::ordered_json;

int Scene::materialIndex(const std::string& n) const {
  for (size_t i = 0; i < materials.size(); ++i)
    if (materials[i].name == n) return int(i);
  return -1;
}

namespace {

struct Ctx {
  std::string source;
  [[noreturn]] void fail(const std::string& path, const std::string& msg) const {
    throw Error(source + ": " + (path.empty() ? "" : path + ": ") + msg);
  }
};

std::string fmtNum(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

double readNumber(const Ctx& c, const json& j, const std::string& path, const ParamDecl& d,
                  bool integer) {
  if (!j.is_number())
    c.fail(path, std::string("expected ") + (integer ? "an integer" : "a number") + ", got " +
                     j.type_name());
  const double v = j.get<double>();
  if (!std::isfinite(v)) c.fail(path, "must be a finite number");
  if (integer && (j.is_number_float() && v != std::floor(v)))
    c.fail(path, "expected an integer, got " + fmtNum(v));
  if (d.minExclusive ? !(v > d.min) : !(v >= d.min))
    c.fail(path, "must be " + std::string(d.minExclusive ? "> " : ">= ") + fmtNum(d.min) +
                     " (got " + fmtNum(v) + ")");
  if (!(v <= d.max)) c.fail(path, "must be <= " + fmtNum(d.max) + " (got " + fmtNum(v) + ")");
  return v;
}

ParamValue readValue(const Ctx& c, const json& j, const std::string& path, const ParamDecl& d) {
  ParamValue v;
  switch (d.type) {
    case ParamType::Bool:
      if (!j.is_boolean())
        c.fail(path, std::string("expected true or false, got ") + j.type_name());
      v.num = {j.get<bool>() ? 1.0 : 0.0};
      return v;
    case ParamType::Float:
    case ParamType::Int:
      v.num = {readNumber(c, j, path, d, d.type == ParamType::Int)};
      return v;
    case ParamType::Rgb:
    case ParamType::Vec2:
    case ParamType::Vec3:
    case ParamType::Int2: {
      const int n = paramArity(d.type);
      if (d.type == ParamType::Rgb && j.is_number()) {  // a grey shorthand
        const double g = readNumber(c, j, path, d, false);
        v.num = {g, g, g};
        return v;
      }
      if (!j.is_array() || int(j.size()) != n)
        c.fail(path, std::string("expected an ") + paramTypeName(d.type) + ", got " +
                         (j.is_array() ? "an array of " + std::to_string(j.size())
                                       : std::string(j.type_name())));
      for (int k = 0; k < n; ++k)
        v.num.push_back(readNumber(c, j[k], path + "[" + std::to_string(k) + "]", d,
                                   d.type == ParamType::Int2));
      return v;
    }
    case ParamType::Enum: {
      if (!j.is_string()) c.fail(path, std::string("expected a string, got ") + j.type_name());
      v.str = j.get<std::string>();
      bool ok = false;
      std::string list;
      for (const auto& ch : d.choices) {
        ok |= ch == v.str;
        list += (list.empty() ? "" : ", ") + ch;
      }
      if (!ok) c.fail(path, "unknown value '" + v.str + "' (expected one of: " + list + ")");
      return v;
    }
    case ParamType::String:
    case ParamType::Path:
      if (!j.is_string()) c.fail(path, std::string("expected a string, got ") + j.type_name());
      v.str = j.get<std::string>();
      if (d.type == ParamType::Path && v.str.empty()) c.fail(path, "path must not be empty");
      return v;
  }
  return v;
}

/// Reads the keys of `obj` declared by `decl`; keys in `reserved` are skipped (read elsewhere);
/// any other key is an error naming it.
ParamSet readParams(const Ctx& c, const json& obj, const std::string& path, const TypeDecl& decl,
                    std::initializer_list<const char*> reserved = {}) {
  if (!obj.is_object()) c.fail(path, std::string("expected an object, got ") + obj.type_name());
  ParamSet s = defaultParams(decl);
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    bool skip = false;
    for (const char* r : reserved) skip |= it.key() == r;
    if (skip) continue;
    const std::string kp = path + (path.empty() ? "" : ".") + it.key();
    const ParamDecl* d = decl.find(it.key());
    if (!d) {
      std::string known;
      for (const auto& p : decl.params) known += (known.empty() ? "" : ", ") + p.name;
      c.fail(kp, "unknown key for " + decl.category + " '" + decl.name +
                     "' (known keys: " + (known.empty() ? std::string("none") : known) + ")");
    }
    s.set(d->name, readValue(c, it.value(), kp, *d));
  }
  for (const auto& p : decl.params)
    if (p.required && !obj.contains(p.name))
      c.fail(path, "missing required key '" + p.name + "' (" + p.doc + ")");
  return s;
}

json valueToJson(const ParamDecl& d, const ParamValue& v) {
  switch (d.type) {
    case ParamType::Bool:
      return v.num.at(0) != 0;
    case ParamType::Int:
      return int64_t(v.num.at(0));
    case ParamType::Float:
      return v.num.at(0);
    case ParamType::Int2:
      return json::array({int64_t(v.num.at(0)), int64_t(v.num.at(1))});
    case ParamType::Rgb:
    case ParamType::Vec2:
    case ParamType::Vec3: {
      json a = json::array();
      for (double x : v.num) a.push_back(x);
      return a;
    }
    default:
      return v.str;
  }
}

void writeParams(json& out, const TypeDecl& decl, const ParamSet& s) {
  for (const auto& p : decl.params) out[p.name] = valueToJson(p, s.at(p.name));
}

}  // namespace

Scene parseScene(const std::string& text, const std::string& source,
                 const std::filesystem::path& baseDir) {
  Ctx c{source};
  const json root = parseJsonText(text, source);
  if (!root.is_object()) c.fail("", "the scene must be a JSON object");
  Scene s;
  s.source = source;
  s.baseDir = baseDir;
  for (auto it = root.begin(); it != root.end(); ++it) {
    static const char* known[] = {"btfscene", "name", "tile", "materials", "parts", "simulation"};
    bool ok = false;
    for (const char* k : known) ok |= it.key() == k;
    if (!ok)
      c.fail(it.key(),
             "unknown top-level key (known: btfscene, name, tile, materials, parts, simulation)");
  }
  if (!root.contains("btfscene")) c.fail("", "missing 'btfscene' (the format version, 1)");
  if (!root["btfscene"].is_number_integer() || root["btfscene"].get<int>() != kSceneVersion)
    c.fail("btfscene", "unsupported scene format version (this build reads version " +
                           std::to_string(kSceneVersion) + ")");
  if (root.contains("name")) {
    if (!root["name"].is_string()) c.fail("name", "expected a string");
    s.name = root["name"].get<std::string>();
  }
  ParamSet tile = readParams(c, root.value("tile", json::object()), "tile", tileDecl());
  s.Lx = tile.v2("size").x;
  s.Ly = tile.v2("size").y;
  s.simulation =
      readParams(c, root.value("simulation", json::object()), "simulation", simulationDecl());

  if (!root.contains("materials")) c.fail("", "missing 'materials' (an object of named materials)");
  const json& mats = root["materials"];
  if (!mats.is_object())
    c.fail("materials", std::string("expected an object, got ") + mats.type_name());
  for (auto it = mats.begin(); it != mats.end(); ++it) {
    const std::string path = "materials." + it.key();
    const json& m = it.value();
    if (!m.is_object()) c.fail(path, "expected an object");
    if (!m.contains("type") || !m["type"].is_string())
      c.fail(path, "missing 'type' (one of: " + typeNames(materialTypes()) + ")");
    const std::string type = m["type"].get<std::string>();
    const TypeDecl* d = findType(materialTypes(), type);
    if (!d)
      c.fail(path + ".type",
             "unknown material type '" + type + "' (one of: " + typeNames(materialTypes()) + ")");
    s.materials.push_back({it.key(), type, readParams(c, m, path, *d, {"type"})});
  }
  if (s.materials.size() > 65535) c.fail("materials", "at most 65535 materials");

  if (!root.contains("parts")) c.fail("", "missing 'parts' (an array of parts)");
  const json& parts = root["parts"];
  if (!parts.is_array())
    c.fail("parts", std::string("expected an array, got ") + parts.type_name());
  if (parts.empty()) c.fail("parts", "the scene is empty: add at least one part");
  for (size_t i = 0; i < parts.size(); ++i) {
    const std::string path = "parts[" + std::to_string(i) + "]";
    const json& p = parts[i];
    if (!p.is_object()) c.fail(path, "expected an object");
    if (!p.contains("type") || !p["type"].is_string())
      c.fail(path, "missing 'type' (one of: " + typeNames(partTypes()) + ")");
    const std::string type = p["type"].get<std::string>();
    const TypeDecl* d = findType(partTypes(), type);
    if (!d)
      c.fail(path + ".type",
             "unknown part type '" + type + "' (one of: " + typeNames(partTypes()) + ")");
    PartDef part;
    part.type = type;
    part.name = p.contains("name") && p["name"].is_string() ? p["name"].get<std::string>()
                                                            : type + std::to_string(i);
    if (!p.contains("material") || !p["material"].is_string())
      c.fail(path, "missing 'material' (the name of one of the scene's materials)");
    part.material = p["material"].get<std::string>();
    if (s.materialIndex(part.material) < 0)
      c.fail(path + ".material", "no material named '" + part.material + "'");
    part.params = readParams(c, p, path, *d, {"type", "name", "material", "transform", "array"});
    part.transform =
        readParams(c, p.value("transform", json::object()), path + ".transform", transformDecl());
    part.array = readParams(c, p.value("array", json::object()), path + ".array", arrayDecl());
    s.parts.push_back(std::move(part));
  }
  return s;
}

Scene loadScene(const std::filesystem::path& path) {
  checkInputFile(path.string(), "scene file", kMaxSceneFileBytes, "64 MiB");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path.string() + ": cannot open scene file");
  std::stringstream ss;
  ss << f.rdbuf();
  return parseScene(ss.str(), path.string(), path.parent_path());
}

std::string sceneToJson(const Scene& s) {
  json root;
  root["btfscene"] = kSceneVersion;
  root["name"] = s.name;
  json tile;
  tile["size"] = json::array({s.Lx, s.Ly});
  root["tile"] = tile;
  json mats = json::object();
  for (const auto& m : s.materials) {
    json o;
    o["type"] = m.type;
    writeParams(o, *findType(materialTypes(), m.type), m.params);
    mats[m.name] = o;
  }
  root["materials"] = mats;
  json parts = json::array();
  for (const auto& p : s.parts) {
    json o;
    o["name"] = p.name;
    o["type"] = p.type;
    o["material"] = p.material;
    writeParams(o, *findType(partTypes(), p.type), p.params);
    json t, a;
    writeParams(t, transformDecl(), p.transform);
    writeParams(a, arrayDecl(), p.array);
    o["transform"] = t;
    o["array"] = a;
    parts.push_back(o);
  }
  root["parts"] = parts;
  json sim;
  writeParams(sim, simulationDecl(), s.simulation);
  root["simulation"] = sim;
  return root.dump(2);
}

std::filesystem::path resolvePath(const Scene& scene, const std::string& p) {
  std::filesystem::path path(p);
  return path.is_absolute() ? path : scene.baseDir / path;
}

namespace {
json schemaOfParam(const ParamDecl& d) {
  json s;
  s["description"] = d.doc;
  auto numSchema = [&](bool integer) {
    json n;
    n["type"] = integer ? "integer" : "number";
    if (std::isfinite(d.min)) n[d.minExclusive ? "exclusiveMinimum" : "minimum"] = d.min;
    if (std::isfinite(d.max)) n["maximum"] = d.max;
    return n;
  };
  switch (d.type) {
    case ParamType::Bool:
      s["type"] = "boolean";
      break;
    case ParamType::Float:
      s.update(numSchema(false));
      break;
    case ParamType::Int:
      s.update(numSchema(true));
      break;
    case ParamType::Rgb:
    case ParamType::Vec2:
    case ParamType::Vec3:
    case ParamType::Int2: {
      json arr;
      arr["type"] = "array";
      arr["items"] = numSchema(d.type == ParamType::Int2);
      arr["minItems"] = arr["maxItems"] = paramArity(d.type);
      if (d.type == ParamType::Rgb) {
        s["oneOf"] = json::array({arr, numSchema(false)});
      } else {
        s.update(arr);
      }
      break;
    }
    case ParamType::Enum:
      s["type"] = "string";
      s["enum"] = d.choices;
      break;
    default:
      s["type"] = "string";
      s["minLength"] = 1;
  }
  if (d.type != ParamType::Path) {
    json def = valueToJson(d, ParamValue{d.def, d.defStr});
    s["default"] = def;
  }
  return s;
}
json schemaOfType(const TypeDecl& t, bool withType, std::initializer_list<const char*> extra) {
  json o;
  o["type"] = "object";
  o["description"] = t.doc;
  json props = json::object();
  json req = json::array();
  if (withType) {
    props["type"] = json{{"const", t.name}};
    req.push_back("type");
  }
  for (const char* e : extra) props[e] = json{{"$ref", std::string("#/$defs/") + e}};
  for (const auto& p : t.params) {
    props[p.name] = schemaOfParam(p);
    if (p.required) req.push_back(p.name);
  }
  o["properties"] = props;
  if (!req.empty()) o["required"] = req;
  o["additionalProperties"] = false;
  return o;
}
}  // namespace

std::string sceneJsonSchema() {
  json s;
  s["$schema"] = "https://json-schema.org/draft/2020-12/schema";
  s["title"] = "BTF Studio scene, version 1";
  s["type"] = "object";
  s["required"] = json::array({"btfscene", "materials", "parts"});
  s["additionalProperties"] = false;
  json defs;
  json mats = json::array();
  for (const auto& t : materialTypes()) mats.push_back(schemaOfType(t, true, {}));
  json parts = json::array();
  for (const auto& t : partTypes()) {
    json o = schemaOfType(t, true, {"transform", "array"});
    o["properties"]["name"] = json{{"type", "string"}};
    o["properties"]["material"] = json{{"type", "string"}};
    o["required"].push_back("material");
    parts.push_back(o);
  }
  defs["transform"] = schemaOfType(transformDecl(), false, {});
  defs["array"] = schemaOfType(arrayDecl(), false, {});
  s["$defs"] = defs;
  json props;
  props["btfscene"] = json{{"const", kSceneVersion}};
  props["name"] = json{{"type", "string"}};
  props["tile"] = schemaOfType(tileDecl(), false, {});
  props["simulation"] = schemaOfType(simulationDecl(), false, {});
  props["materials"] = json{{"type", "object"}, {"additionalProperties", json{{"oneOf", mats}}}};
  props["parts"] = json{{"type", "array"}, {"minItems", 1}, {"items", json{{"oneOf", parts}}}};
  s["properties"] = props;
  return s.dump(2) + "\n";
}

}  // namespace btf

namespace btf {

std::string sceneParamsMarkdown() {
  std::ostringstream o;
  auto fmt = [](double v) {
    std::ostringstream s;
    s.precision(12);
    s << v;
    return s.str();
  };
  auto table = [&](const TypeDecl& t) {
    o << t.doc << "\n\n| key | type | range | default | meaning |\n|---|---|---|---|---|\n";
    for (const auto& p : t.params) {
      std::string range;
      if (p.type == ParamType::Enum) {
        for (const auto& c : p.choices) range += (range.empty() ? "" : ", ") + ("`" + c + "`");
      } else if (paramArity(p.type) > 0 && p.type != ParamType::Bool) {
        range =
            (std::isfinite(p.min) ? (p.minExclusive ? "> " : "≥ ") + fmt(p.min) : std::string()) +
            (std::isfinite(p.min) && std::isfinite(p.max) ? ", " : "") +
            (std::isfinite(p.max) ? "≤ " + fmt(p.max) : std::string());
      }
      std::string def;
      if (p.required)
        def = "required";
      else if (paramArity(p.type) == 0)
        def = "`" + p.defStr + "`";
      else if (p.type == ParamType::Bool)
        def = p.def[0] != 0 ? "`true`" : "`false`";
      else {
        for (double d : p.def) def += (def.empty() ? "" : ", ") + fmt(d);
        if (p.def.size() > 1) def = "[" + def + "]";
        def = "`" + def + "`";
      }
      o << "| `" << p.name << "` | " << paramTypeName(p.type) << " | " << range << " | " << def
        << " | " << p.doc << " |\n";
    }
    o << "\n";
  };
  o << "### Tile (`tile`)\n\n";
  table(tileDecl());
  o << "### Simulation defaults (`simulation`)\n\n";
  table(simulationDecl());
  o << "### Materials\n\n";
  for (const auto& t : materialTypes()) {
    o << "#### `" << t.name << "`\n\n";
    table(t);
  }
  o << "### Parts\n\nEvery part also takes `name` (string), `material` (required: a key of "
       "`materials`), "
       "`transform` and `array`.\n\n";
  for (const auto& t : partTypes()) {
    o << "#### `" << t.name << "`\n\n";
    table(t);
  }
  o << "### `transform`\n\n";
  table(transformDecl());
  o << "### `array`\n\n";
  table(arrayDecl());
  return o.str();
}

}  // namespace btf
