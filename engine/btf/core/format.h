// printf into a std::string (messages, reports): the whole text, however long.
#pragma once
#include <string>

namespace btf {

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

}  // namespace btf
