// Pairs files of `btfsim brdf --pairs FILE.csv`.
#include <btf/core/error.h>
#include <btf/sim/brdf_probe.h>

#include <cmath>
#include <fstream>

#include "fuzz.h"

namespace btf::fuzz {

const char* const kTargetName = "pairs";

std::string cliArgs(const uint8_t* data, size_t size) {
  const std::string csv = writeInput(data, size, "csv");
  const std::string scene = inputDir() + "/plane.json";
  std::ofstream(scene) << R"({"btfscene": 1, "materials": {"m": {"type": "lambert"}},
    "parts": [{"type": "plane", "material": "m"}]})";
  return "brdf " + scene + " --pairs " + csv + " --spp 1";
}

void btfFuzzOne(const uint8_t* data, size_t size) {
  const std::string path = inputDir() + "/input.csv";
  std::vector<std::array<double, 4>> deg;
  const auto pairs =
      parsePairsFile(std::string(reinterpret_cast<const char*>(data), size), path, &deg);
  check(pairs.size() == deg.size(), "pairs and their angles differ in count");
  for (const auto& p : pairs)
    for (const DVec3& w : {p.wi, p.wo})
      check(std::isfinite(w.x) && std::isfinite(w.y) && w.z >= 0 &&
                std::abs(glm::length(w) - 1.0) < 1e-9,
            "a direction that is not a unit vector of the upper hemisphere");
}

}  // namespace btf::fuzz
