// Limits on JSON read from files, checked on the text before the recursive parser sees it:
// nlohmann's parser recurses once per nesting level, so a file of a million '[' would overflow
// the stack. Our formats nest a handful of levels; 64 leaves room and refuses hostile input.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace btf {

constexpr int kMaxJsonDepth = 64;

/// Throws btf::Error "SOURCE:LINE: JSON nested deeper than N levels" when arrays and objects
/// (outside strings) nest deeper than `maxDepth`.
void checkJsonDepth(std::string_view text, const std::string& source, int maxDepth = kMaxJsonDepth);

/// Parses JSON text read from a file: the depth is checked first (checkJsonDepth), and a syntax
/// error becomes "SOURCE:LINE:COLUMN: JSON syntax error near 'EXCERPT'" (or "invalid UTF-8",
/// "a number beyond the range of a double") — our words, never the JSON library's.
nlohmann::json parseJsonText(const std::string& text, const std::string& source,
                             int maxDepth = kMaxJsonDepth);

/// The fields of a file's JSON header, read by JSON pointer with errors that name the file, the
/// field and the rule ("F: header field /texels/0: must be an integer in 1..16384") instead of
/// the JSON library's text.
class JsonFields {
 public:
  JsonFields(const nlohmann::json& j, std::string file) : m_j(j), m_file(std::move(file)) {}
  const nlohmann::json& at(const std::string& ptr) const;
  int64_t integer(const std::string& ptr, int64_t lo, int64_t hi) const;
  double number(const std::string& ptr) const;  // finite
  std::string string(const std::string& ptr) const;
  bool boolean(const std::string& ptr, bool def) const;  // absent: def
  [[noreturn]] void fail(const std::string& ptr, const std::string& rule) const;

 private:
  const nlohmann::json& m_j;
  std::string m_file;
};

}  // namespace btf
