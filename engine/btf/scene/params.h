// Parameters declared once (Mitsuba's Properties/traverse idea): each part, material and settings
// type lists its parameters with name, type, range, default and doc. The scene reader, writer,
// JSON Schema and the studio's editor all walk these declarations; nothing else knows the keys.
#pragma once
#include <btf/core/math.h>

#include <array>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace btf {

enum class ParamType { Float, Int, Bool, Rgb, Vec2, Vec3, Int2, String, Enum, Path };
const char* paramTypeName(ParamType t);
/// Number of numeric components of a type (0 for strings, enums and paths).
int paramArity(ParamType t);

struct ParamDecl {
  std::string name;
  ParamType type = ParamType::Float;
  std::vector<double> def;  // numeric default (arity components)
  std::string defStr;       // string / enum / path default
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool minExclusive = false;  // value must be > min rather than >= min
  bool required = false;
  std::vector<std::string> choices;  // for Enum
  std::string doc;
  bool repeatable = false;  // a command option given several times (values joined by ';')
};

struct TypeDecl {
  std::string category;  // "material", "part", "transform", "array", "simulation", "tile"
  std::string name;
  std::string doc;
  std::vector<ParamDecl> params;
  const ParamDecl* find(const std::string& key) const;
};

struct ParamValue {
  std::vector<double> num;
  std::string str;
  bool operator==(const ParamValue&) const = default;
};

/// The values of one declared object, every declared key present (defaults filled in).
class ParamSet {
 public:
  double f(const std::string& k) const { return at(k).num.at(0); }
  int i(const std::string& k) const { return int(at(k).num.at(0)); }
  bool b(const std::string& k) const { return at(k).num.at(0) != 0.0; }
  Vec2 v2(const std::string& k) const;
  Vec3 v3(const std::string& k) const;
  std::array<int, 2> i2(const std::string& k) const;
  const std::string& s(const std::string& k) const { return at(k).str; }
  const ParamValue& at(const std::string& k) const;
  void set(const std::string& k, ParamValue v) { m_values[k] = std::move(v); }
  void erase(const std::string& k) { m_values.erase(k); }
  bool has(const std::string& k) const { return m_values.count(k) != 0; }
  const std::map<std::string, ParamValue>& values() const { return m_values; }
  bool operator==(const ParamSet&) const = default;

 private:
  std::map<std::string, ParamValue> m_values;
};

/// Defaults of every parameter of a type.
ParamSet defaultParams(const TypeDecl& decl);

// The registry of declared types.
const std::vector<TypeDecl>& materialTypes();
const std::vector<TypeDecl>& partTypes();
const TypeDecl& transformDecl();
const TypeDecl& arrayDecl();
const TypeDecl& simulationDecl();
const TypeDecl& tileDecl();
/// nullptr when unknown.
const TypeDecl* findType(const std::vector<TypeDecl>& types, const std::string& name);
std::string typeNames(const std::vector<TypeDecl>& types);

}  // namespace btf
