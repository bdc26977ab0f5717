#include <btf/core/format.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>

namespace btf {

std::string format(const char* fmt, ...) {
  va_list a;
  va_start(a, fmt);
  va_list b;
  va_copy(b, a);
  const int n = std::vsnprintf(nullptr, 0, fmt, a);
  va_end(a);
  std::string s(size_t(std::max(0, n)), '\0');
  std::vsnprintf(s.data(), s.size() + 1, fmt, b);
  va_end(b);
  return s;
}

}  // namespace btf
