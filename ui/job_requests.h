// The studio's jobs as the engine's requests (btf/ops): the Jobs panel and the script fill a
// JobForm, these functions turn it into the same Request `btfsim` builds from argv, and opJob
// runs it with the form's thread count in an arena of its own. Nothing here chains the simulator
// and an encoder: that lives once, in the engine.
#pragma once
#include <btf/ops/ops.h>
#include <btf/scene/scene.h>

#include <functional>
#include <memory>
#include <string>

#include "jobs.h"

namespace btf::ui {

/// What the Jobs panel edits. `sim` holds the simulation options the user set in the form; a
/// key it does not give (texels, dirs, spp, shadows, …) takes the scene's "simulation" block, so
/// an edit in the scene panel reaches the next job.
struct JobForm {
  std::string output = "out/studio";
  ops::Request sim{"simulate"};
  /// Codec options (β, ranks, colour model…) for compress and stream jobs; `codec` and
  /// `targetRatio` below choose the codec and its target.
  ops::Request codecOptions{"compress"};
  std::string codec = "nmf";
  double targetRatio = 300;
  std::string exportFormat = "ubo2003";
  bool resume = true;
  int threads = 1;  // 1 leaves the other core to the UI (the preview keeps its own arena)
  JobForm();
};

/// simulate (codec "" = a raw store; else streamed into that codec, as --compress).
ops::Request simulateRequest(const JobForm& f, const std::string& scenePath,
                             const std::string& output, const std::string& codec);
ops::Request compressRequest(const JobForm& f, const std::string& input, const std::string& output,
                             const std::string& codec, bool compare);
ops::Request exportRequest(const JobForm& f, const std::string& input, const std::string& format,
                           const std::string& output);
/// A quick sweep for the study panel (minutes at most; btfsim study runs the full one).
ops::Request studyRequest(const JobForm& f, const std::string& scenePath, const std::string& dir,
                          int texels);

/// A job running `r` (on the edited `scene` when given). `done` gets the report on the main
/// thread after a successful run. A cancel ends it as Cancelled with no output; a simulation's
/// .partial is removed unless the job was stopped (kept for a resume).
std::unique_ptr<Job> opJob(const ops::Request& r, std::shared_ptr<const Scene> scene,
                           std::function<void(const ops::Report&)> done = {});

}  // namespace btf::ui
