#include <btf/core/error.h>

namespace btf::detail {

void checkFailed(const char* expr, const char* file, int line, const std::string& msg) {
  std::string s =
      std::string("internal check failed: ") + expr + " at " + file + ":" + std::to_string(line);
  if (!msg.empty()) s += " (" + msg + ")";
  throw Error(s);
}

}  // namespace btf::detail
