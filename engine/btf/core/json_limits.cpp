#include <btf/core/error.h>
#include <btf/core/json_limits.h>

#include <cmath>

namespace btf {

void checkJsonDepth(std::string_view text, const std::string& source, int maxDepth) {
  int depth = 0, line = 1;
  bool inString = false, escaped = false;
  for (char ch : text) {
    if (ch == '\n') ++line;
    if (inString) {
      if (escaped)
        escaped = false;
      else if (ch == '\\')
        escaped = true;
      else if (ch == '"')
        inString = false;
      continue;
    }
    if (ch == '"') {
      inString = true;
    } else if (ch == '[' || ch == '{') {
      if (++depth > maxDepth)
        throw Error(source + ":" + std::to_string(line) + ": JSON nested deeper than " +
                    std::to_string(maxDepth) + " levels");
    } else if (ch == ']' || ch == '}') {
      --depth;
    }
  }
}

void JsonFields::fail(const std::string& ptr, const std::string& rule) const {
  throw Error(m_file + ": header field " + ptr + ": " + rule);
}

const nlohmann::json& JsonFields::at(const std::string& ptr) const {
  try {
    const nlohmann::json::json_pointer p(ptr);
    if (!m_j.contains(p)) fail(ptr, "missing");
    return m_j.at(p);
  } catch (const nlohmann::json::exception&) {
    fail(ptr, "missing");
  }
}

int64_t JsonFields::integer(const std::string& ptr, int64_t lo, int64_t hi) const {
  const auto& v = at(ptr);
  if (!v.is_number_integer() || v.get<int64_t>() < lo || v.get<int64_t>() > hi ||
      (v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(hi)))
    fail(ptr, "must be an integer in " + std::to_string(lo) + ".." + std::to_string(hi));
  return v.get<int64_t>();
}

double JsonFields::number(const std::string& ptr) const {
  const auto& v = at(ptr);
  if (!v.is_number() || !std::isfinite(v.get<double>())) fail(ptr, "must be a finite number");
  return v.get<double>();
}

std::string JsonFields::string(const std::string& ptr) const {
  const auto& v = at(ptr);
  if (!v.is_string()) fail(ptr, "must be a string");
  return v.get<std::string>();
}

bool JsonFields::boolean(const std::string& ptr, bool def) const {
  const nlohmann::json::json_pointer p(ptr);
  if (!m_j.contains(p)) return def;
  const auto& v = m_j.at(p);
  if (!v.is_boolean()) fail(ptr, "must be true or false");
  return v.get<bool>();
}

}  // namespace btf
