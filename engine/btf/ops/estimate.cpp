// The estimate of a simulation (engine/btf/ops/estimate.h).
#include <btf/core/sysinfo.h>
#include <btf/core/run_context.h>
#include <btf/ops/estimate.h>
#include <btf/ops/ops.h>
#include <btf/sim/simulator.h>

#include <sstream>

namespace btf::ops {

std::string SimulationEstimate::line() const {
  std::ostringstream t;
  t << "estimate: " << formatSeconds(seconds) << " on " << threads << " thread(s), memory "
    << formatBytes(double(memoryBytes)) << ", disk " << formatBytes(double(diskBytes));
  if (!refusal.empty()) t << " — refused: " << refusal;
  return t.str();
}

SimulationEstimate estimateSimulation(const Scene& scene, const Request& simulate,
                                      const std::string& output, int threads) {
  SimulationEstimate out;
  withThreads(threads, [&] {
    SimOptions o = simOptions(scene, simulate);
    o.progress = false;
    SimulationJob job(scene, o);
    const SimEstimate e = job.estimate(output);
    out.seconds = e.seconds;
    out.hitMapSeconds = e.hitMapSeconds;
    out.abrdfSeconds = e.evalSeconds;
    out.threads = e.threads;
    out.memoryBytes = e.memoryBytes;
    out.diskBytes = e.diskBytes;
    out.refusal = e.refusal;
  });
  return out;
}

}  // namespace btf::ops
