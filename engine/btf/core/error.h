// Errors of the engine: btf::Error carries a user-facing message (file, JSON path or line, and
// the rule broken). CHECK is an always-on invariant; it throws so the CLI and the app can report
// and keep the user's work instead of aborting.
#pragma once
#include <stdexcept>
#include <string>

namespace btf {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A library's message made fit for one line of ours: the first line, at most 160 characters.
inline std::string oneLine(std::string s) {
  const size_t nl = s.find_first_of("\r\n");
  if (nl != std::string::npos) s.resize(nl);
  if (s.size() > 160) s = s.substr(0, 157) + "...";
  return s.empty() ? "no detail" : s;
}

namespace detail {
[[noreturn]] void checkFailed(const char* expr, const char* file, int line, const std::string& msg);
}

}  // namespace btf

#define BTF_CHECK(cond)                                                     \
  do {                                                                      \
    if (!(cond)) ::btf::detail::checkFailed(#cond, __FILE__, __LINE__, ""); \
  } while (0)
#define BTF_CHECK_MSG(cond, msg)                                               \
  do {                                                                         \
    if (!(cond)) ::btf::detail::checkFailed(#cond, __FILE__, __LINE__, (msg)); \
  } while (0)
#ifdef NDEBUG
#define BTF_DCHECK(cond) \
  do {                   \
  } while (0)
#else
#define BTF_DCHECK(cond) BTF_CHECK(cond)
#endif
