// The estimate of a simulation as a use case: what a `simulate` request would take in time,
// memory and disk, or why it would be refused — the figures `btfsim plan` and every simulate
// print before they start, and what the studio's Jobs form shows as the user edits (on a
// background thread: the estimate runs a short calibration).
#pragma once
#include <btf/ops/request.h>

#include <cstdint>
#include <string>

namespace btf {
struct Scene;
}

namespace btf::ops {

/// A typed report (the fields of docs/schemas/plan.json's "estimate" that a front door shows).
struct SimulationEstimate {
  double seconds = 0, hitMapSeconds = 0, abrdfSeconds = 0;
  int threads = 1;
  uint64_t memoryBytes = 0, diskBytes = 0;
  std::string refusal;  // non-empty when the run would be refused (budget, disk)
  /// "estimate: 12.3 s on 2 thread(s), memory 40 MiB, disk 8 MiB[ — refused: …]"
  std::string line() const;
};

/// Estimates `simulate` (a validated simulate request) on `scene` writing `output`, on
/// `threads` threads (0 = every core), without progress bars. Throws btf::Error on a bad scene.
SimulationEstimate estimateSimulation(const Scene& scene, const Request& simulate,
                                      const std::string& output, int threads);

}  // namespace btf::ops
