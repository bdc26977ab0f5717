// study.csv tables (what `btfsim study` writes and the studio's accuracy-vs-time view reads).
#include <btf/core/error.h>
#include <btf/sim/study.h>

#include <cmath>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "study";

std::string cliArgs(const uint8_t* data, size_t size) {
  // btfsim writes study tables and never reads them (the studio does, through this parser), so
  // this target has no --btfsim test (tests/fuzz/CMakeLists.txt).
  throw Error(writeInput(data, size, "csv") + ": study tables are read by the studio only");
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = inputDir() + "/study.csv";
  const auto rows = parseStudyCsv(std::string(reinterpret_cast<const char*>(data), size), path);
  for (const auto& r : rows)
    check(std::isfinite(r.seconds) && r.seconds >= 0 && std::isfinite(r.error) && r.error >= 0 &&
              r.spp >= 0,
          "a study row with a value outside its rule");
}

}  // namespace btf::fuzz
