#include <btf/core/error.h>
#include <btf/ops/request.h>

#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

namespace btf::ops {

using json = nlohmann::ordered_json;

const ParamDecl* CommandDecl::find(const std::string& key) const {
  for (const auto& o : options)
    if (o.name == key) return &o;
  return nullptr;
}

const CommandDecl& command(const std::string& name) {
  std::string known;
  for (const auto& c : commands()) {
    if (c.name == name) return c;
    known += (known.empty() ? "" : ", ") + c.name;
  }
  throw Error("unknown command '" + name + "' (expected one of " + known + ")");
}

std::string optionName(const CommandDecl& c, const std::string& key) {
  for (const auto& p : c.positional)
    if (p == key) {
      std::string u = key;
      for (char& ch : u) ch = char(std::toupper(static_cast<unsigned char>(ch)));
      return u;
    }
  std::string s = "--" + key;
  for (char& ch : s)
    if (ch == '_') ch = '-';
  return s;
}

namespace {

std::string fmtNum(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string rangeText(const ParamDecl& d) {
  if (d.type == ParamType::Bool) return "";
  if (d.type == ParamType::Enum) {
    std::string s;
    for (const auto& c : d.choices) s += (s.empty() ? "" : ", ") + c;
    return "one of " + s;
  }
  if (d.type != ParamType::Int && d.type != ParamType::Float) return "";
  const bool lo = std::isfinite(d.min), hi = std::isfinite(d.max);
  if (lo && hi && d.minExclusive) return "in (" + fmtNum(d.min) + ", " + fmtNum(d.max) + "]";
  if (lo && hi) return "in " + fmtNum(d.min) + ".." + fmtNum(d.max);
  if (lo) return std::string(d.minExclusive ? "> " : ">= ") + fmtNum(d.min);
  if (hi) return "<= " + fmtNum(d.max);
  return "";
}

std::string defaultText(const CommandDecl& c, const ParamDecl& d) {
  if (c.sceneKeys.count(d.name)) return "the scene's";
  if (d.required) return "required";
  if (d.type == ParamType::Bool) return "off";
  if (paramArity(d.type) > 0) return fmtNum(d.def.at(0));
  return d.defStr.empty() ? "none" : d.defStr;
}

}  // namespace

Request::Request(const std::string& name) : m_decl(&ops::command(name)) {
  for (const auto& d : m_decl->options) {
    if (m_decl->sceneKeys.count(d.name)) continue;
    ParamValue v;
    v.num = d.def;
    v.str = d.defStr;
    m_values.set(d.name, v);
  }
}

Request& Request::set(const std::string& key, const std::string& text) {
  const ParamDecl* d = m_decl->find(key);
  if (!d) throw Error(m_decl->name + ": unknown option '" + key + "'");
  const std::string name = optionName(*m_decl, key);
  ParamValue v;
  switch (d->type) {
    case ParamType::Int:
    case ParamType::Float: {
      double x = 0;
      const char* b = text.data();
      const char* e = b + text.size();
      const auto r = std::from_chars(b, e, x);
      if (text.empty() || r.ec != std::errc() || r.ptr != e || !std::isfinite(x))
        throw Error(name + ": expected " +
                    (d->type == ParamType::Int ? "an integer" : "a finite number") + ", got '" +
                    text + "'");
      if (d->type == ParamType::Int && x != std::floor(x))
        throw Error(name + ": expected an integer, got '" + text + "'");
      if (x < d->min || x > d->max || (d->minExclusive && x <= d->min))
        throw Error(name + ": must be " + rangeText(*d) + " (got " + text + ")");
      v.num = {x};
      break;
    }
    case ParamType::Bool:
      if (text == "true" || text == "1" || text == "on")
        v.num = {1};
      else if (text == "false" || text == "0" || text == "off")
        v.num = {0};
      else
        throw Error(name + ": expected true or false, got '" + text + "'");
      break;
    case ParamType::Enum: {
      bool ok = false;
      for (const auto& c : d->choices) ok |= c == text;
      if (!ok) throw Error(name + ": must be " + rangeText(*d) + " (got '" + text + "')");
      v.str = text;
      break;
    }
    default:
      if (d->required && text.empty()) throw Error(name + ": must not be empty");
      v.str = text;
  }
  m_values.set(key, v);
  m_given.insert(key);
  return *this;
}

Request& Request::set(const std::string& key, double v) {
  return set(key, fmtNum(v));
}

Request& Request::setFlag(const std::string& key, bool v) {
  return set(key, std::string(v ? "true" : "false"));
}

void Request::unset(const std::string& key) {
  m_given.erase(key);
  const ParamDecl* d = m_decl->find(key);
  if (!d) return;
  if (m_decl->sceneKeys.count(key)) {
    m_values.erase(key);  // the scene's value again
    return;
  }
  ParamValue v;
  v.num = d->def;
  v.str = d->defStr;
  m_values.set(key, v);
}

void Request::validate() const {
  for (const auto& d : m_decl->options)
    if (d.required && !given(d.name))
      throw Error(m_decl->name + ": " + optionName(*m_decl, d.name) + " is required");
}

std::string Request::text(const std::string& k) const {
  const ParamDecl* d = m_decl->find(k);
  if (!d) throw Error(m_decl->name + ": unknown option '" + k + "'");
  const ParamValue& v = m_values.at(k);
  if (d->type == ParamType::Bool) return v.num.at(0) != 0 ? "true" : "false";
  if (paramArity(d->type) > 0) return fmtNum(v.num.at(0));
  return v.str;
}

std::string Request::toJson() const {
  json o = json::object();
  for (const auto& d : m_decl->options) {
    if (!m_values.has(d.name)) continue;
    const ParamValue& v = m_values.at(d.name);
    if (d.type == ParamType::Bool)
      o[d.name] = v.num.at(0) != 0;
    else if (d.type == ParamType::Int)
      o[d.name] = int64_t(v.num.at(0));
    else if (d.type == ParamType::Float)
      o[d.name] = v.num.at(0);
    else
      o[d.name] = v.str;
  }
  json j;
  j["command"] = m_decl->name;
  j["options"] = o;
  return j.dump();
}

std::string commandsMarkdown() {
  std::ostringstream s;
  s << "<!-- generated by `btfsim cli-doc` from engine/btf/ops/declarations.cpp; "
       "a test fails when this part is stale -->\n";
  for (const auto& c : commands()) {
    s << "\n### `btfsim " << c.name;
    for (const auto& p : c.positional) s << " " << optionName(c, p);
    s << "`\n\n"
      << c.doc << ".\n\n| option | type | range | default | meaning |\n"
      << "|---|---|---|---|---|\n";
    for (const auto& d : c.options) {
      std::string nm = optionName(c, d.name);
      if (d.name == "output") nm = "-o, --output";
      if (d.name == "quiet") nm = "-q, --quiet";
      std::string doc = d.doc;
      for (auto pos = doc.find('|'); pos != std::string::npos; pos = doc.find('|', pos + 2))
        doc.replace(pos, 1, "\\|");
      s << "| `" << nm << "` | " << paramTypeName(d.type) << " | " << rangeText(d) << " | "
        << defaultText(c, d) << " | " << doc << " |\n";
    }
  }
  return s.str();
}

std::string requestSchema(const std::string& name) {
  const CommandDecl& c = command(name);
  json props = json::object();
  json required = json::array();
  for (const auto& d : c.options) {
    json p;
    p["description"] = d.doc;
    switch (d.type) {
      case ParamType::Int:
        p["type"] = "integer";
        break;
      case ParamType::Float:
        p["type"] = "number";
        break;
      case ParamType::Bool:
        p["type"] = "boolean";
        break;
      default:
        p["type"] = "string";
    }
    if (std::isfinite(d.min)) p[d.minExclusive ? "exclusiveMinimum" : "minimum"] = d.min;
    if (std::isfinite(d.max)) p["maximum"] = d.max;
    if (d.type == ParamType::Enum) p["enum"] = d.choices;
    if (!c.sceneKeys.count(d.name) && !d.required) {
      if (d.type == ParamType::Bool)
        p["default"] = false;
      else if (d.type == ParamType::Int)
        p["default"] = int64_t(d.def.at(0));
      else if (d.type == ParamType::Float)
        p["default"] = d.def.at(0);
      else
        p["default"] = d.defStr;
    }
    if (d.required) required.push_back(d.name);
    props[d.name] = p;
  }
  json j;
  j["$schema"] = "https://json-schema.org/draft/2020-12/schema";
  j["title"] = "btfsim " + c.name + " request";
  j["description"] = c.doc;
  j["type"] = "object";
  j["properties"] = {{"command", {{"const", c.name}}},
                     {"options",
                      {{"type", "object"},
                       {"additionalProperties", false},
                       {"required", required},
                       {"properties", props}}}};
  j["required"] = {"command", "options"};
  return j.dump(2) + "\n";
}

}  // namespace btf::ops
