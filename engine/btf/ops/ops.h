// The use cases, run: one function per request, one run context, one report. The CLI turns argv
// into a Request and the report into text or JSON; the studio turns a form into a Request and
// the report into a panel. Nothing above this floor chains the simulator, the encoders or the
// writers (docs/architecture.md).
#pragma once
#include <btf/core/run_context.h>
#include <btf/core/error.h>
#include <btf/ops/reports.h>
#include <btf/ops/request.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace btf {
struct SimOptions;
struct Scene;
struct CodecSettings;
}  // namespace btf

namespace btf::ops {

/// What a use case returns: `result` its typed report (reports.h: the fields of
/// docs/schemas/COMMAND.json), `json` the same serialised, as `--json` prints it (with the
/// request echoed), `text` the human summary for stdout, `notes` lines for stderr (the plan, the
/// estimate, warnings), `outputs` the files written.
struct Report {
  std::string command;
  Result result;
  nlohmann::ordered_json json = nlohmann::ordered_json::object();
  std::string text;
  std::vector<std::string> notes, warnings, outputs;
  /// One line for the studio's job list.
  std::string summary;
  /// The typed report of command T (CompressResult for compress…); throws btf::Error when the
  /// report holds another.
  template <class T>
  const T& as() const {
    if (const T* t = std::get_if<T>(&result)) return *t;
    throw Error("the report of '" + command + "' is not the one asked for");
  }
};

/// Runs a request (validated first). Cancellation throws btf::Cancelled and leaves no output
/// and no .partial behind (the studio's "stop" keeps the .partial: ctx.keepPartial).
Report run(const Request& r, const RunContext& ctx);

/// Receives the notes (plan, estimate) as soon as they are known, before the long work: the CLI
/// prints them to stderr, the studio shows them in the job.
using NoteSink = std::function<void(const std::string&)>;
/// `scene`, when given, is used instead of loading the request's scene file (the studio's edited
/// document; relative mesh paths were resolved when it was parsed).
Report run(const Request& r, const RunContext& ctx, const NoteSink& notes,
           const Scene* scene = nullptr);

// The translations every use case shares (tests call them too).
/// The scene's simulation block with the request's scene-backed options applied.
SimOptions simOptions(const Scene& scene, const Request& r);
CodecSettings codecSettings(const Request& r, const std::string& codec);
/// "64" → (64, 64); "64x32" → (64, 32). Throws btf::Error naming `option` (the one the user
/// gave: --texels, --size) and the text.
void parseTexels(const std::string& s, int* nu, int* nv, const std::string& option = "--texels");
/// "30,45" → (30, 45), θ in [0, 90) (a BTF direction) or, with maxTheta = 180, in [0, 180]
/// (a camera or light around an object). Throws btf::Error naming `what` and the text.
void parseAnglePair(const std::string& s, const std::string& what, double* theta, double* phi,
                    double maxTheta = 90);

}  // namespace btf::ops
