// The studio's job launchers and inspector loaders: what the Jobs panel's buttons and the
// script's actions call. Each job is the engine's request for the matching btfsim command
// (job_requests.h), run by the engine's use-case layer.
#include <btf/compress/cbtf.h>
#include <btf/compress/export.h>
#include <btf/core/error.h>
#include <btf/core/input_file.h>
#include <btf/core/sysinfo.h>
#include <btf/ops/estimate.h>
#include <btf/ops/ops.h>
#include <btf/render/objects.h>
#include <btf/sim/simulator.h>
#include <btf/sim/study.h>
#include <imgui.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>

#include "app.h"

namespace btf::ui {

namespace fs = std::filesystem;

namespace {

std::string docPath(const Document& doc) {
  return doc.path().empty() ? std::string("(unsaved scene)") : doc.path().string();
}

}  // namespace

std::string App::simulationEstimate() {
  // The estimate runs a short calibration simulation: on a background thread, never in a frame.
  if (m_estimate.valid() &&
      m_estimate.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    estimateCache = m_estimate.get();
  }
  const std::string out = form.output + ".btf";
  const ops::Request req = simulateRequest(form, docPath(doc), out, "");
  const std::string key = req.toJson() + std::to_string(doc.revision());
  if (key != estimateKey && !m_estimate.valid() && !ImGui::IsAnyItemActive()) {
    estimateKey = key;
    const Scene scene = doc.scene();
    const int threads = form.threads;
    m_estimate = std::async(std::launch::async, [scene, req, out, threads]() -> std::string {
      try {
        return ops::estimateSimulation(scene, req, out, threads).line();
      } catch (const std::exception& e) {
        return std::string("estimate failed: ") + e.what();
      }
    });
  }
  if (key != estimateKey || m_estimate.valid()) return estimateCache + " (estimating…)";
  return estimateCache;
}

int App::startSimulation(const std::string& output, bool compressToo) {
  const ops::Request req = simulateRequest(form, docPath(doc), output, "");
  auto job = opJob(req, std::make_shared<const Scene>(doc.scene()),
                   [this, output](const ops::Report&) { insp.reference = output; });
  job->title = "simulate " + doc.scene().name + " → " + output;
  job->estimate = simulationEstimate();
  const int id = jobs.submit(std::move(job));
  if (compressToo) {
    const std::string cb = fs::path(output).replace_extension(".cbtf").string();
    startCompression(output, cb);
  }
  message("queued simulation → " + output);
  return id;
}

int App::startStreamedSimulation(const std::string& output) {
  // The same request as `btfsim simulate --compress CODEC`: the engine checks the encoder's
  // memory against the budget and streams the chunks into it.
  const ops::Request req = simulateRequest(form, docPath(doc), output, form.codec);
  auto job =
      opJob(req, std::make_shared<const Scene>(doc.scene()), [this, output](const ops::Report&) {
        try {
          openCompressed(output, "");
        } catch (const std::exception& e) {
          message(e.what(), true);
        }
      });
  job->title = "simulate " + doc.scene().name + " → " + form.codec + " stream → " + output;
  job->estimate = simulationEstimate() + " (no raw file is written)";
  message("queued streamed simulation → " + output);
  return jobs.submit(std::move(job));
}

int App::startCompression(const std::string& input, const std::string& output) {
  const ops::Request req = compressRequest(form, input, output, form.codec, false);
  auto job = opJob(req, nullptr, [this, output, input](const ops::Report&) {
    try {
      openCompressed(output, input);
    } catch (const std::exception& e) {
      message(e.what(), true);
    }
  });
  job->title = "compress " + input + " (" + form.codec + ") → " + output;
  job->estimate = "memory: bounded by the codec's state (see docs/compression.md)";
  message("queued compression → " + output);
  return jobs.submit(std::move(job));
}

int App::startStudy(const std::string& dir) {
  const SimOptions fo = ops::simOptions(doc.scene(), form.sim);
  const ops::Request req = studyRequest(form, docPath(doc), dir, std::min(fo.nu, 8));
  auto job = opJob(req, std::make_shared<const Scene>(doc.scene()),
                   [this, dir](const ops::Report&) { loadStudy(dir); });
  job->title = "study " + doc.scene().name + " → " + dir;
  job->estimate = "one simulation per configuration, plus the path-traced reference";
  message("queued study → " + dir);
  return jobs.submit(std::move(job));
}

int App::startExport(const std::string& input, const std::string& format,
                     const std::string& output) {
  const ops::Request req = exportRequest(form, input, format, output);  // validates the format
  auto job = opJob(req, nullptr);
  job->title = "export " + input + " as " + format + " → " + output;
  message("queued export → " + output);
  return jobs.submit(std::move(job));
}

int App::startObjectRender(const std::string& mode, int spp, int size, const std::string& output) {
  if (insp.compressed.empty())
    throw Error("render on the CPU: open a compressed BTF first (Inspector, or a job)");
  // The viewer's view in the renderer's terms (viewerRenderSettings: the same settings the GPU's
  // mapped view and its check use).
  const int height = std::max(8, int(std::lround(size * 0.75)));
  const RenderSettings s =
      viewerRenderSettings(obj, btf::makeObject(obj.shape).radius, size, height);
  const std::string out = output.empty() ? form.output + "/objects_" + mode + ".png" : output;
  ops::Request req("render");
  req.set("input", insp.compressed).set("output", out).set("mode", mode);
  req.set("object", obj.shape).set("tiling", s.tiling);
  req.set("relief_scale", s.reliefScale).set("spp", double(spp));
  req.set("size", std::to_string(size) + "x" + std::to_string(height));
  char angles[96];
  std::snprintf(angles, sizeof angles, "%.6g,%.6g", s.camTheta, s.camPhi);
  req.set("camera", angles);
  std::snprintf(angles, sizeof angles, "%.6g,%.6g", s.lightTheta, s.lightPhi);
  req.set("light", angles);
  req.set("projection", "perspective").set("fov", s.fovDeg).set("zoom", s.zoom);
  req.set("exposure", double(obj.exposure));
  if (!insp.reference.empty()) req.set("vmf", insp.reference);
  req.set("threads", double(form.threads));
  auto job = opJob(req, nullptr, [this, out](const ops::Report& rep) {
    obj.cpuImagePath = out;
    // One line per mode: time, and the error against the exact image when there is one.
    std::string text;
    for (const auto& im : rep.as<ops::RenderResult>().images) {
      char line[256];
      std::snprintf(line, sizeof line, "%-6s %7.2f s", im.mode.c_str(), im.seconds);
      text += line;
      if (im.errorVsExact) {
        std::snprintf(line, sizeof line, "   vs exact: relative RMSE %.1f %%, coverage %.2f %%",
                      100 * im.errorVsExact->relRmse, 100 * im.errorVsExact->coverageMismatch);
        text += line;
      }
      text += "\n";
    }
    obj.cpuText = text + "exact | mapped | flat | |mapped - exact| (magenta: coverage differs)";
    obj.cpuDirty = true;
    report()["object_render"] = rep.json;
  });
  job->title = "render " + insp.compressed + " on " + obj.shape + " (" + mode + ") → " + out;
  job->estimate = "the CPU renderer (docs/render.md)";
  message("queued CPU render → " + out);
  return jobs.submit(std::move(job));
}

void App::openCompressed(const std::string& path, const std::string& reference) {
  auto c = std::make_shared<CompressedBtf>(readCompressed(path));
  // The object view decodes on the GPU, whose decoder has no half-vector resampling.
  if (c->paramsJson.find("\"halfway\":true") != std::string::npos)
    throw Error(path +
                ": a tensor file in half-vector coordinates (--halfway) has no GPU decoder; "
                "btfsim reads it (info, compare, render) — recompress without --halfway for the "
                "studio");
  insp.decoder = makeDecoder(*c);
  insp.cbtf = c;
  insp.compressed = path;
  insp.ratio = c->ratio();
  insp.haveReport = false;
  insp.texturesDirty = true;
  insp.view = insp.light = 0;
  std::ostringstream s;
  s << c->codec << " (" << c->colour << "), " << c->info.nu << "×" << c->info.nv << " texels, "
    << c->info.nDirs() << " directions (" << c->info.directionSet
    << "), ratio 1:" << int(c->ratio() + 0.5) << ", " << formatBytes(double(c->fileBytes()));
  insp.header = s.str();
  insp.reference = reference;
  insp.refDecoder.reset();
  if (!reference.empty()) insp.refDecoder = openBtf(reference);
  obj.bound.clear();  // the object viewer re-binds the new arrays
  message("opened " + path);
}

void App::compareInspector() {
  if (!insp.decoder) throw Error("open a compressed BTF first");
  if (!insp.refDecoder) throw Error("the inspector has no reference (raw) BTF to compare with");
  auto job = std::make_unique<Job>();
  job->kind = "compare";
  job->title = "compare " + insp.compressed;
  // Decoders are read-only and thread-safe for reads; the job holds them through the app,
  // which keeps them until the comparison ends (the inspector waits for it).
  const std::shared_ptr<const Decoder> ref = insp.refDecoder, dec = insp.decoder;
  auto result = std::make_shared<ErrorReport>();
  const int threads = form.threads;
  job->run = [ref, dec, result, threads](Job& j) {
    withThreads(threads, [&] { *result = compareBtfs(*ref, *dec, false, 16, &j.cancel); });
    std::ostringstream s;
    s << "relative RMSE " << 100 * result->relRmse << " %, PSNR " << result->psnr << " dB";
    return s.str();
  };
  job->onDone = [this, result](Job&) {
    insp.report = *result;
    insp.haveReport = true;
    insp.texturesDirty = true;
    InspectorState::Row row{insp.cbtf ? insp.cbtf->codec : "?", insp.ratio, result->rmse,
                            result->relRmse, result->psnr};
    std::erase_if(insp.codecs, [&](const InspectorState::Row& r) { return r.codec == row.codec; });
    insp.codecs.push_back(row);
  };
  insp.comparing = jobs.submit(std::move(job));
}

int App::startCodecSweep(const std::string& reference) {
  if (reference.empty()) throw Error("the codec sweep needs a raw reference BTF");
  int last = 0;
  for (const std::string& codec : codecNames()) {
    const std::string out =
        fs::path(reference).replace_extension("").string() + "." + codec + ".cbtf";
    // `btfsim compress --compare`: the report carries the error against the reference.
    const ops::Request req = compressRequest(form, reference, out, codec, true);
    auto job = opJob(req, nullptr, [this, codec](const ops::Report& rep) {
      const auto& res = rep.as<ops::CompressResult>();
      if (!res.error) return;  // --compare always measures it
      const InspectorState::Row row{codec, res.file.ratio, res.error->rmse, res.error->relRmse,
                                    res.error->psnr};
      std::erase_if(insp.codecs, [&](const InspectorState::Row& r) { return r.codec == codec; });
      insp.codecs.push_back(row);
    });
    job->title = "compress + compare " + codec + " → " + out;
    last = jobs.submit(std::move(job));
  }
  message("queued the " + std::to_string(codecNames().size()) +
          " codecs at 1:" + std::to_string(int(form.targetRatio)));
  return last;
}

void App::loadStudy(const std::string& dir) {
  study = StudyState{};
  study.dir = dir;
  const std::string file = dir + "/study.csv";
  std::vector<StudyRow> rows;
  try {
    checkInputFile(file, "study table", uint64_t(64) << 20, "64 MiB");
    std::ifstream f(file, std::ios::binary);
    std::stringstream text;
    text << f.rdbuf();
    rows = parseStudyCsv(text.str(), file);
  } catch (const Error& e) {
    study.error = e.what();
    throw;
  }
  // The configuration the job form would simulate with (directions and spp; network method).
  const SimOptions fo = ops::simOptions(doc.scene(), form.sim);
  for (const StudyRow& r : rows) {
    study.points.push_back({r.config, r.seconds, r.error, r.pareto});
    if (study.chosen.empty() && r.dirs == fo.directions && r.spp == fo.spp &&
        r.config.rfind("pt ", 0) != 0)
      study.chosen = r.config;
  }
  message("loaded study " + dir + " (" + std::to_string(study.points.size()) + " configurations)");
}

}  // namespace btf::ui
