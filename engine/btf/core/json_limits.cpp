#include <btf/core/error.h>
#include <btf/core/json_limits.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string_view>

namespace btf {

namespace {
/// Calls f(i, line) for every character of `text` outside JSON strings (quotes included in
/// neither); f returns the index to continue after (i to go on character by character).
template <class F>
void scanOutsideStrings(std::string_view text, F&& f) {
  size_t line = 1;
  bool inString = false, escaped = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
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
    if (ch == '"')
      inString = true;
    else
      i = f(i, line);
  }
}
}  // namespace

void checkJsonDepth(std::string_view text, const std::string& source, int maxDepth) {
  int depth = 0;
  scanOutsideStrings(text, [&](size_t i, size_t line) {
    const char ch = text[i];
    if (ch == '[' || ch == '{') {
      if (++depth > maxDepth)
        throw Error(source + ":" + std::to_string(line) + ": JSON nested deeper than " +
                    std::to_string(maxDepth) + " levels");
    } else if (ch == ']' || ch == '}') {
      --depth;
    }
    return i;
  });
}

nlohmann::json parseJsonText(const std::string& text, const std::string& source, int maxDepth) {
  checkJsonDepth(text, source, maxDepth);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    const size_t at = std::min(text.size(), e.byte > 0 ? size_t(e.byte - 1) : size_t(0));
    size_t line = 1, col = 1;
    for (size_t i = 0; i < at; ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    const std::string what = e.what();
    std::string rule = "JSON syntax error";
    if (what.find("UTF-8") != std::string::npos)
      rule = "invalid UTF-8 in a JSON string";
    else if (at >= text.size())
      rule = "JSON text ends too early";
    // A short excerpt of the text before the error, printable ASCII only.
    std::string near;
    for (size_t i = at >= 24 ? at - 24 : 0; i <= at && i < text.size(); ++i) {
      const unsigned char ch = static_cast<unsigned char>(text[i]);
      near += ch >= 32 && ch < 127 ? char(ch) : (ch == '\n' ? ' ' : '?');
    }
    throw Error(source + ":" + std::to_string(line) + ":" + std::to_string(col) + ": " + rule +
                (near.empty() ? "" : " near '" + near + "'"));
  } catch (const nlohmann::json::out_of_range&) {
    // The library says which literal but not where: find the first number (outside strings)
    // that overflows a double.
    scanOutsideStrings(text, [&](size_t i, size_t line) {
      const char ch = text[i];
      if (!(ch == '-' || (ch >= '0' && ch <= '9')) ||
          (i > 0 && std::string_view(",:[ \t\r\n").find(text[i - 1]) == std::string::npos))
        return i;
      size_t j = i + 1;
      while (j < text.size() &&
             std::string_view("0123456789.eE+-").find(text[j]) != std::string_view::npos)
        ++j;
      const std::string lit = text.substr(i, std::min<size_t>(j - i, 40));
      if (std::isinf(std::strtod(lit.c_str(), nullptr)))
        throw Error(source + ":" + std::to_string(line) + ": the number " + lit +
                    " is beyond the range of a double (about 1.8e308)");
      return j - 1;
    });
    throw Error(source + ": a JSON number beyond the range of a double (about 1.8e308)");
  } catch (const nlohmann::json::exception&) {
    throw Error(source + ": malformed JSON");
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
