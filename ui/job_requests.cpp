#include "job_requests.h"

#include <filesystem>

namespace btf::ui {

namespace fs = std::filesystem;

JobForm::JobForm() {
  sim.set("scene", std::string("(document)")).set("output", output + ".btf");
}

namespace {

void common(const JobForm& f, ops::Request& r) {
  r.set("threads", double(f.threads)).setFlag("quiet", true);
}

// The codec options the form gives, onto a request that declares them.
void codecOptions(const JobForm& f, ops::Request& r) {
  for (const auto& d : f.codecOptions.decl().options)
    if (f.codecOptions.given(d.name) && r.decl().find(d.name) && d.name != "input" &&
        d.name != "output" && d.name != "threads" && d.name != "quiet" && d.name != "json" &&
        (d.name != "memory_budget" || r.command() == "compress"))
      r.set(d.name, f.codecOptions.text(d.name));
}

}  // namespace

ops::Request simulateRequest(const JobForm& f, const std::string& scenePath,
                             const std::string& output, const std::string& codec) {
  ops::Request r = f.sim;
  r.set("scene", scenePath.empty() ? std::string("(document)") : scenePath);
  r.set("output", output);
  r.setFlag("resume", f.resume && fs::exists(output + ".partial"));
  if (!codec.empty()) {
    r.set("compress", codec);
    codecOptions(f, r);
    if (!r.given("target_ratio")) r.set("target_ratio", f.targetRatio);
  }
  common(f, r);
  return r;
}

ops::Request compressRequest(const JobForm& f, const std::string& input, const std::string& output,
                             const std::string& codec, bool compare) {
  ops::Request r("compress");
  codecOptions(f, r);
  r.set("input", input).set("output", output).set("codec", codec);
  r.set("target_ratio", f.targetRatio).setFlag("compare", compare);
  common(f, r);
  return r;
}

ops::Request exportRequest(const JobForm& f, const std::string& input, const std::string& format,
                           const std::string& output) {
  ops::Request r("export");
  r.set("input", input).set("format", format).set("output", output);
  common(f, r);
  return r;
}

ops::Request studyRequest(const JobForm& f, const std::string& scenePath, const std::string& dir,
                          int texels) {
  ops::Request r("study");
  r.set("scene", scenePath.empty() ? std::string("(document)") : scenePath).set("output", dir);
  r.set("texels", std::to_string(texels)).set("dirs", std::string("8x16,4x8"));
  r.set("spp", std::string("1,2")).set("bounces", std::string("3,1"));
  r.set("shadows", std::string("map")).set("network_voxels", std::string("0"));
  r.set("gather", std::string("4")).set("links", std::string("16"));
  r.set("reference_spp", 32.0).set("image_spp", 1.0).set("image_paths", 1.0);
  common(f, r);
  return r;
}

std::unique_ptr<Job> opJob(const ops::Request& r, std::shared_ptr<const Scene> scene,
                           std::function<void(const ops::Report&)> done) {
  auto job = std::make_unique<Job>();
  job->kind = r.command();
  job->output = r.has("output") ? r.s("output") : std::string();
  auto report = std::make_shared<ops::Report>();
  job->run = [r, scene, report](Job& j) {
    RunContext ctx;
    ctx.cancel = &j.cancel;
    ctx.progress = false;
    ctx.keepPartial = true;  // the job's cleanup decides (stop keeps it for a resume)
    if (!j.output.empty() && !fs::path(j.output).parent_path().empty())
      fs::create_directories(fs::path(j.output).parent_path());
    *report = ops::run(r, ctx, nullptr, scene.get());
    return report->summary;
  };
  const std::string out = job->output;
  job->cleanup = [out](Job& j) {
    if (j.keepPartial) return;
    std::error_code ec;
    fs::remove(out + ".partial", ec);
  };
  if (done) job->onDone = [report, done](Job&) { done(*report); };
  return job;
}

}  // namespace btf::ui
