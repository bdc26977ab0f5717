// The studio's job launchers and inspector loaders: what the Jobs panel's buttons and the
// script's actions call. Each job runs the same engine calls as the matching btfsim command.
#include <btf/compress/cbtf.h>
#include <btf/compress/export.h>
#include <btf/core/error.h>
#include <btf/core/sysinfo.h>
#include <btf/sim/simulator.h>
#include <imgui.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>

#include "app.h"

namespace btf::ui {

namespace fs = std::filesystem;

namespace {

SimOptions formOptions(const Scene& scene, const JobForm& f) {
  SimOptions o = optionsFromScene(scene);
  o.nu = o.nv = f.texels;
  o.directions = f.directions;
  o.spp = f.spp;
  o.progress = false;
  return o;
}

void removePartial(const std::string& path) {
  std::error_code ec;
  fs::remove(path + ".partial", ec);
}

}  // namespace

std::string App::simulationEstimate() {
  // The estimate runs a short calibration simulation: on a background thread, never in a frame.
  if (m_estimate.valid() &&
      m_estimate.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    estimateCache = m_estimate.get();
  }
  const std::string key = std::to_string(form.texels) + form.directions + std::to_string(form.spp) +
                          std::to_string(doc.revision());
  if (key != estimateKey && !m_estimate.valid() && !ImGui::IsAnyItemActive()) {
    estimateKey = key;
    const Scene scene = doc.scene();
    const SimOptions o = formOptions(scene, form);
    const std::string out = form.output + ".btf";
    m_estimate = std::async(std::launch::async, [scene, o, out]() -> std::string {
      try {
        SimulationJob job(scene, o);
        const SimEstimate e = job.estimate(out);
        std::ostringstream s;
        s << "estimate: " << formatSeconds(e.seconds) << " on " << e.threads
          << " thread(s), memory " << formatBytes(double(e.memoryBytes)) << ", disk "
          << formatBytes(double(e.diskBytes));
        if (!e.refusal.empty()) s << " — refused: " << e.refusal;
        return s.str();
      } catch (const std::exception& e) {
        return std::string("estimate failed: ") + e.what();
      }
    });
  }
  if (key != estimateKey || m_estimate.valid()) return estimateCache + " (estimating…)";
  return estimateCache;
}

int App::startSimulation(const std::string& output, bool compressToo) {
  auto job = std::make_unique<Job>();
  job->kind = "simulate";
  job->title = "simulate " + doc.scene().name + " → " + output;
  job->output = output;
  job->estimate = simulationEstimate();
  const Scene scene = doc.scene();  // a copy: the user keeps editing
  SimOptions o = formOptions(scene, form);
  o.resume = form.resume && fs::exists(output + ".partial");
  const int threads = form.threads;
  job->run = [scene, o, output, threads](Job& j) {
    ThreadLimit limit(threads);
    if (!fs::path(output).parent_path().empty())
      fs::create_directories(fs::path(output).parent_path());
    SimulationJob sim(scene, o);
    sim.setCancel(&j.cancel);
    const SimEstimate est = sim.estimate(output);
    if (!est.refusal.empty()) throw Error("refusing to start: " + est.refusal);
    const SimReport r = sim.run(output, est, &j.cancel);
    if (r.cancelled) return std::string("cancelled");
    std::ostringstream s;
    s << "wrote " << output << " (" << formatBytes(double(r.outputBytes)) << ") in "
      << formatSeconds(r.wallSeconds);
    if (r.chunksResumed) s << ", " << r.chunksResumed << " chunk(s) resumed";
    return s.str();
  };
  job->cleanup = [output](Job& j) {
    if (!j.keepPartial) removePartial(output);
  };
  job->onDone = [this, output](Job&) { insp.reference = output; };
  const int id = jobs.submit(std::move(job));
  if (compressToo) {
    const std::string cb = fs::path(output).replace_extension(".cbtf").string();
    startCompression(output, cb);
  }
  message("queued simulation → " + output);
  return id;
}

int App::startStreamedSimulation(const std::string& output) {
  auto job = std::make_unique<Job>();
  job->kind = "simulate";
  job->title = "simulate " + doc.scene().name + " → " + form.codec + " stream → " + output;
  job->output = output;
  job->estimate = simulationEstimate() + " (no raw file is written)";
  const Scene scene = doc.scene();
  const SimOptions o = formOptions(scene, form);
  CodecSettings cs;
  cs.codec = form.codec;
  cs.targetRatio = form.targetRatio;
  validate(cs);
  const int threads = form.threads;
  job->run = [scene, o, cs, output, threads](Job& j) {
    // The same stream as `btfsim simulate --compress`: training texels first, then every chunk
    // straight into the encoder.
    ThreadLimit limit(threads);
    if (!fs::path(output).parent_path().empty())
      fs::create_directories(fs::path(output).parent_path());
    SimulationJob sim(scene, o);
    sim.setCancel(&j.cancel);
    const SimEstimate est = sim.estimate("");
    if (!est.refusal.empty()) throw Error("refusing to start: " + est.refusal);
    auto enc = makeEncoder(cs, sim.storeInfo(est.chunkTexels));
    sim.setTrainingTexels(enc->trainingTexels(), [&](const float* v) { enc->train(v); });
    sim.setChunkSink([&](int, int64_t t0, int64_t t1, const float* v) { enc->add(t0, t1, v); });
    const SimReport r = sim.run("", est, &j.cancel);
    if (r.cancelled) return std::string("cancelled");
    const CompressedBtf c = enc->finish();
    writeCompressed(output, c);
    std::ostringstream s;
    s << "wrote " << output << ", ratio 1:" << int(c.ratio() + 0.5) << " in "
      << formatSeconds(r.wallSeconds);
    return s.str();
  };
  job->cleanup = [output](Job&) { removePartial(output); };
  job->onDone = [this, output](Job&) {
    try {
      openCompressed(output, "");
    } catch (const std::exception& e) {
      message(e.what(), true);
    }
  };
  message("queued streamed simulation → " + output);
  return jobs.submit(std::move(job));
}

int App::startCompression(const std::string& input, const std::string& output) {
  auto job = std::make_unique<Job>();
  job->kind = "compress";
  job->title = "compress " + input + " (" + form.codec + ") → " + output;
  job->output = output;
  CodecSettings cs;
  cs.codec = form.codec;
  cs.targetRatio = form.targetRatio;
  validate(cs);
  job->estimate = "memory: bounded by the codec's state (see docs/compression.md)";
  const int threads = form.threads;
  job->run = [input, output, cs, threads](Job& j) {
    ThreadLimit limit(threads);
    CompressReport rep;
    const CompressedBtf c = compressStore(input, cs, false, &j.cancel, &rep);
    if (j.cancel.cancelled()) return std::string("cancelled");
    writeCompressed(output, c);
    std::ostringstream s;
    s << "wrote " << output << ", ratio 1:" << int(c.ratio() + 0.5) << " in "
      << formatSeconds(rep.seconds);
    return s.str();
  };
  job->cleanup = [output](Job&) { removePartial(output); };
  job->onDone = [this, output, input](Job&) {
    try {
      openCompressed(output, input);
    } catch (const std::exception& e) {
      message(e.what(), true);
    }
  };
  message("queued compression → " + output);
  return jobs.submit(std::move(job));
}

int App::startStudy(const std::string& dir) {
  auto job = std::make_unique<Job>();
  job->kind = "study";
  job->title = "study " + doc.scene().name + " → " + dir;
  job->output = dir;
  job->estimate = "one simulation per configuration, plus the path-traced reference";
  const Scene scene = doc.scene();
  const int texels = std::min(form.texels, 8);
  const int threads = form.threads;
  job->run = [scene, dir, texels, threads](Job& j) {
    ThreadLimit limit(threads);
    StudyOptions so;
    so.nu = so.nv = texels;
    // A quick sweep for the panel (minutes at most); btfsim study runs the full one.
    so.base.dirs = "8x16";
    so.dirs = {"4x8", "8x16"};
    so.spp = {1, 2};
    so.bounces = {1, 3};
    so.referenceSamples = 32;
    so.imageSpp = 1;
    so.imagePaths = 1;
    so.progress = false;
    so.cancel = &j.cancel;
    Study st = runStudy(scene, so);
    fs::create_directories(dir);
    writeStudy(st, dir);
    return "wrote " + dir + "/study.csv (" + std::to_string(st.results.size()) + " configurations)";
  };
  job->onDone = [this, dir](Job&) { loadStudy(dir); };
  message("queued study → " + dir);
  return jobs.submit(std::move(job));
}

int App::startExport(const std::string& input, const std::string& format,
                     const std::string& output) {
  if (format != "ubo2003" && format != "ubo2014" && format != "merl")
    throw Error("unknown export format '" + format + "' (expected ubo2003, ubo2014 or merl)");
  auto job = std::make_unique<Job>();
  job->kind = "export";
  job->title = "export " + input + " as " + format + " → " + output;
  job->output = output;
  const int threads = form.threads;
  job->run = [input, format, output, threads](Job& j) {
    ThreadLimit limit(threads);
    const auto dec = openBtf(input);
    if (format == "ubo2003") {
      const int64_t n = exportUbo2003(*dec, output, false);
      return "wrote " + std::to_string(n) + " images in " + output;
    }
    if (format == "ubo2014") {
      exportUbo2014(*dec, output, 16, false);
      return "wrote " + output;
    }
    exportMerl(*dec, output, 16, false);
    return "wrote " + output;
  };
  message("queued export → " + output);
  return jobs.submit(std::move(job));
}

void App::openCompressed(const std::string& path, const std::string& reference) {
  auto c = std::make_shared<CompressedBtf>(readCompressed(path));
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
    ThreadLimit limit(threads);
    *result = compareBtfs(*ref, *dec, false, 16, &j.cancel);
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
  std::shared_ptr<const Decoder> ref = openBtf(reference);
  int last = 0;
  for (const char* codec : {"nmf", "svd", "perview", "lpca"}) {
    auto job = std::make_unique<Job>();
    job->kind = "compress";
    const std::string out =
        fs::path(reference).replace_extension("").string() + "." + codec + ".cbtf";
    job->title = std::string("compress + compare ") + codec + " → " + out;
    job->output = out;
    CodecSettings cs;
    cs.codec = codec;
    cs.targetRatio = form.targetRatio;
    validate(cs);
    const int threads = form.threads;
    auto row = std::make_shared<InspectorState::Row>();
    job->run = [reference, out, cs, threads, ref, row](Job& j) {
      ThreadLimit limit(threads);
      CompressReport rep;
      const CompressedBtf c = compressStore(reference, cs, false, &j.cancel, &rep);
      if (j.cancel.cancelled()) return std::string("cancelled");
      writeCompressed(out, c);
      const auto dec = makeDecoder(c);
      const ErrorReport e = compareBtfs(*ref, *dec, false, 16, &j.cancel);
      *row = {cs.codec, c.ratio(), e.rmse, e.relRmse, e.psnr};
      std::ostringstream s;
      s << cs.codec << ": 1:" << int(c.ratio() + 0.5) << ", relative RMSE " << 100 * e.relRmse
        << " %";
      return s.str();
    };
    job->cleanup = [out](Job&) { removePartial(out); };
    job->onDone = [this, row](Job&) {
      std::erase_if(insp.codecs,
                    [&](const InspectorState::Row& r) { return r.codec == row->codec; });
      insp.codecs.push_back(*row);
    };
    last = jobs.submit(std::move(job));
  }
  message("queued the four codecs at 1:" + std::to_string(int(form.targetRatio)));
  return last;
}

void App::loadStudy(const std::string& dir) {
  study = StudyState{};
  study.dir = dir;
  std::ifstream f(dir + "/study.csv");
  if (!f) {
    study.error = dir + "/study.csv: cannot open (run a study first)";
    throw Error(study.error);
  }
  std::string line;
  std::getline(f, line);
  std::vector<std::string> head;
  {
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) head.push_back(c);
  }
  auto col = [&](const std::string& n) {
    for (size_t i = 0; i < head.size(); ++i)
      if (head[i] == n) return int(i);
    throw Error(dir + "/study.csv: no column '" + n + "'");
  };
  const int cl = col("config"), cs = col("seconds"), ce = col("probe_rel_rmse"), cp = col("pareto"),
            cd = col("dirs"), cq = col("spp");
  while (std::getline(f, line)) {
    std::vector<std::string> v;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) v.push_back(c);
    if (int(v.size()) <= std::max({cl, cs, ce, cp, cd, cq})) continue;
    std::string label = v[size_t(cl)];
    std::erase(label, '"');
    study.points.push_back(
        {label, std::stod(v[size_t(cs)]), std::stod(v[size_t(ce)]), v[size_t(cp)] == "1"});
    // The configuration the job form would simulate with (directions and spp; network method).
    if (study.chosen.empty() && v[size_t(cd)] == form.directions &&
        v[size_t(cq)] == std::to_string(form.spp) && label.rfind("pt ", 0) != 0)
      study.chosen = label;
  }
  message("loaded study " + dir + " (" + std::to_string(study.points.size()) + " configurations)");
}

}  // namespace btf::ui
