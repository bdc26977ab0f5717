// The accuracy-vs-time study: the simulator's knobs against the path tracer and, with --codecs,
// the compression knobs on the base configuration's BTF.
#include <btf/compress/compress.h>
#include <btf/compress/mip.h>
#include <btf/core/output_lock.h>
#include <btf/core/sysinfo.h>
#include <btf/ops/internal.h>
#include <btf/scene/scene.h>
#include <btf/sim/simulator.h>
#include <btf/sim/study.h>

#include <filesystem>
#include <fstream>

namespace btf::ops::detail {

namespace {

// Over the ranks of a job (docs/cluster.md): the base store is simulated by every rank (its
// chunks spread as in `simulate`), then codec setting i runs on rank i mod N (its time is that
// rank's with its threads) and rank 0 gathers the rows and writes the tables; the pyramids of
// --mip run on rank 0.
void compressionStudy(const Call& c, const Scene& scene, const StudyOptions& o, Comm& comm) {
  const Request& r = c.r;
  const std::string& dir = r.s("output");
  std::vector<double> betas;
  for (const auto& b : splitList(r.s("betas"), "--betas")) {
    char* end = nullptr;
    const double v = std::strtod(b.c_str(), &end);
    if (end == b.c_str() || *end || !(v > 0 && v <= 1))
      throw Error("--betas: value '" + b + "' must be a number in (0, 1]");
    betas.push_back(v);
  }
  const std::vector<int> comps = intList(r.s("components"), "--components", 0, 4096);
  std::vector<CodecSettings> settings;
  for (const auto& name : splitList(r.s("codecs"), "--codecs"))
    for (double beta : name == "nmf" ? betas : std::vector<double>{betas[0]})
      for (int comp : comps) {
        CodecSettings cs = codecSettings(r, name);
        cs.beta = beta;
        cs.components = comp;
        validate(cs);
        settings.push_back(cs);
      }
  const std::string raw = dir + "/base.btf";
  Request sim("simulate");
  sim.set("scene", r.s("scene")).set("output", raw);
  sim.set("texels", std::to_string(o.nu) + "x" + std::to_string(o.nv)).set("dirs", o.base.dirs);
  if (o.base.spp > 0)
    sim.set("spp", double(o.base.spp));
  else
    sim.set("sampling", "adaptive");
  sim.set("shadows", shadowModeName(o.base.shadows));
  sim.set("method", o.base.method);
  SimOptions so = simOptions(scene, sim);
  so.progress = c.progress();
  {
    SimulationJob job(scene, so);
    job.setCancel(c.ctx.cancel);
    job.setComm(&comm);
    SimEstimate est;
    collectively(comm, [&] {
      est = job.estimate(raw);
      if (!est.refusal.empty()) throw Error("compression study: " + est.refusal);
    });
    c.notice("compression study: simulating the base configuration into " + raw);
    job.run(raw, est, c.ctx.cancel);
  }
  struct Row {
    CodecSettings s;
    double seconds = 0, ratio = 0, rmse = 0, rel = 0, psnr = 0;
    uint64_t bytes = 0, rss = 0;
    std::string chosen;
    bool pareto = false;
  };
  std::vector<Row> rows(settings.size());
  for (size_t i = 0; i < settings.size(); ++i) rows[i].s = settings[i];
  std::vector<size_t> mine;
  for (size_t i = size_t(comm.rank()); i < settings.size(); i += size_t(comm.size()))
    mine.push_back(i);
  collectively(comm, [&] {
    const auto ref = openBtf(raw);
    for (size_t i : mine) {
      const CodecSettings& cs = settings[i];
      CompressReport rep;
      CompressedBtf b = compressStore(raw, cs, c.progress() && comm.root(), c.ctx.cancel, &rep);
      const json params = json::parse(b.paramsJson);
      std::string chosen;
      if (params.contains("components_per_channel"))
        chosen = params["components_per_channel"].dump();
      if (params.contains("channels")) {
        // nmf: (slots, view and light components) per channel; tensor: mean (Rv, Rl, Rt).
        json ch = json::array();
        for (const auto& x : params.at("channels")) {
          if (x.contains("slots"))
            ch.push_back({x.at("slots"), x.at("components_view"), x.at("components_light")});
          else if (x.contains("mean_ranks"))
            ch.push_back(x.at("mean_ranks"));
        }
        chosen = ch.dump();
      }
      const auto dec = makeDecoder(std::move(b));
      const ErrorReport e = compareBtfs(*ref, *dec, false, 10, c.ctx.cancel);
      rows[i] = {cs,     rep.seconds,   rep.ratio,        e.rmse, e.relRmse,
                 e.psnr, rep.fileBytes, rep.peakRssBytes, chosen};
    }
  });
  if (comm.distributed()) {
    // Every rank's rows to rank 0, placed by index.
    json part = json::array();
    for (size_t i : mine) {
      const Row& w = rows[i];
      part.push_back({i, w.seconds, w.ratio, w.rmse, w.rel, w.psnr, w.bytes, w.rss, w.chosen});
    }
    const std::vector<std::string> all = comm.gather(part.dump(), 0);
    if (!comm.root()) return;
    for (const std::string& a : all)
      for (const auto& x : json::parse(a)) {
        Row& w = rows[x[0].get<size_t>()];
        w.seconds = x[1], w.ratio = x[2], w.rmse = x[3], w.rel = x[4], w.psnr = x[5];
        w.bytes = x[6], w.rss = x[7], w.chosen = x[8];
      }
  }
  // Pareto front on (size, error): no other row is both smaller and more accurate.
  for (auto& row : rows) {
    row.pareto = true;
    for (const auto& q : rows)
      if (&q != &row && q.bytes <= row.bytes && q.rel <= row.rel &&
          (q.bytes < row.bytes || q.rel < row.rel))
        row.pareto = false;
  }
  std::ofstream csv(dir + "/compression.csv");
  csv << "codec,colour,beta,components,chosen,ratio,bytes,rmse,relative_rmse,psnr_db,seconds,"
         "peak_rss_bytes,pareto\n";
  std::ofstream md(dir + "/compression.md");
  md << "# Compression study: " << scene.name << ", " << o.nu << "x" << o.nv << " texels, "
     << o.base.dirs << ", spp " << o.base.spp << "\n\n"
     << "Error against the uncompressed simulation (" << raw << ").\n\n"
     << "| codec | β | components (chosen) | ratio | RMSE | rel. RMSE | PSNR | time | peak RSS | "
        "Pareto |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::string t = format("%-8s %6s %-24s %8s %9s %9s %8s %8s\n", "codec", "beta", "components",
                         "ratio", "RMSE", "rel.RMSE", "PSNR", "time");
  std::vector<StudyResult::Codec> arr;
  for (const auto& row : rows) {
    const std::string comp = (row.s.components ? std::to_string(row.s.components) : "auto") +
                             (row.chosen.empty() ? "" : " " + row.chosen);
    csv << row.s.codec << "," << row.s.colour << "," << row.s.beta << "," << row.s.components
        << ",\"" << row.chosen << "\"," << row.ratio << "," << row.bytes << "," << row.rmse << ","
        << row.rel << "," << row.psnr << "," << row.seconds << "," << row.rss << ","
        << (row.pareto ? 1 : 0) << "\n";
    md << format("| %s | %s | %s | 1:%.0f | %.4g | %.2f %% | %.1f dB | %.1f s | %s | %s |\n",
                 row.s.codec.c_str(),
                 row.s.codec == "nmf" ? std::to_string(row.s.beta).substr(0, 6).c_str() : "–",
                 comp.c_str(), row.ratio, row.rmse, 100 * row.rel, row.psnr, row.seconds,
                 formatBytes(double(row.rss)).c_str(), row.pareto ? "*" : "");
    t += format("%-8s %6.4f %-24s %7.0f:1 %9.4g %8.2f%% %7.1fdB %7.1fs %s\n", row.s.codec.c_str(),
                row.s.beta, comp.substr(0, 24).c_str(), row.ratio, row.rmse, 100 * row.rel,
                row.psnr, row.seconds, row.pareto ? "*" : "");
    arr.push_back({row.s.codec, row.s.beta, row.s.components, row.ratio, row.bytes, row.rmse,
                   row.rel, row.psnr, row.seconds, row.pareto});
  }
  // Rank 0 holds the configurations' report; the other ranks fill one of their own.
  if (!std::holds_alternative<StudyResult>(c.rep.result)) c.rep.result = StudyResult{};
  StudyResult& res = std::get<StudyResult>(c.rep.result);
  res.compression = std::move(arr);
  c.rep.text += t + "wrote " + dir + "/compression.csv, compression.md\n";
  if (r.b("mip")) {
    // The pyramid (docs/mip.md) of each codec setting at the same target: its size against the
    // single-level file, its time (levels built, encoded, measured) and every level's error.
    std::ofstream pm(dir + "/pyramid.md");
    pm << "# Texel pyramids: " << scene.name << ", " << o.nu << "x" << o.nv << " texels, "
       << o.base.dirs << "\n\nEach level's error against the exact box-filtered level of the "
       << "uncompressed simulation.\n\n| codec | bytes | vs single level | levels built | "
          "total time | relative RMSE per level (level 0 first) |\n|---|---|---|---|---|---|\n";
    std::vector<StudyResult::Pyramid> pj;
    std::string pt = "pyramids (--mip): codec, bytes, vs single, level errors\n";
    for (size_t k = 0; k < settings.size(); ++k) {
      PyramidReport rep;
      const CompressedBtf b = compressPyramid(raw, settings[k], c.progress(), c.ctx.cancel, &rep);
      const double vs = double(rep.fileBytes) / double(std::max<uint64_t>(1, rows[k].bytes));
      std::vector<StudyResult::Pyramid::Level> lv;
      std::string errs;
      for (const auto& l : rep.levels) {
        lv.push_back({l.nu, l.nv, l.relRmse});
        errs += (errs.empty() ? "" : " / ") + format("%.2f %%", 100 * l.relRmse);
      }
      pm << format("| %s | %llu | %.2f× | %.2f s | %.1f s | %s |\n", settings[k].codec.c_str(),
                   (unsigned long long)rep.fileBytes, vs, rep.levelSeconds, rep.seconds,
                   errs.c_str());
      pt += format("%-8s %10llu %6.2fx  %s\n", settings[k].codec.c_str(),
                   (unsigned long long)rep.fileBytes, vs, errs.c_str());
      pj.push_back(
          {settings[k].codec, rep.fileBytes, vs, rep.levelSeconds, rep.seconds, std::move(lv)});
    }
    res.pyramid = std::move(pj);
    c.rep.text += pt + "wrote " + dir + "/pyramid.md\n";
  }
  std::filesystem::remove(raw);
}

}  // namespace

void study(const Call& c) {
  const Request& r = c.r;
  const Scene scene = c.scene();
  StudyOptions o;
  parseTexels(r.s("texels"), &o.nu, &o.nv);
  o.methods = splitList(r.s("method"), "--method");
  for (const auto& m : o.methods)
    if (m != "network" && m != "pt")
      throw Error("--method: value '" + m + "' must be network or pt");
  o.paths = intList(r.s("paths"), "--paths", 1, 4096);
  o.dirs = splitList(r.s("dirs"), "--dirs");
  for (const auto& d : o.dirs) DirectionSet::fromName(d);  // validate early
  o.spp = intList(r.s("spp"), "--spp", 0, 64);
  for (const auto& m : splitList(r.s("shadows"), "--shadows")) {
    const ShadowMode sm = parseShadowMode(m);
    if (sm == ShadowMode::None) throw Error("--shadows: use map or rays");
    o.shadows.push_back(sm);
  }
  o.voxels = intList(r.s("network_voxels"), "--network-voxels", 0, 1024);
  o.gather = intList(r.s("gather"), "--gather", 1, 16);
  o.links = intList(r.s("links"), "--links", 1, 256);
  o.bounces = intList(r.s("bounces"), "--bounces", 0, 64);
  o.base = {o.methods[0], o.dirs[0],  o.spp[0],     o.shadows[0], o.voxels[0],
            o.gather[0],  o.links[0], o.bounces[0], o.paths[0]};
  if (o.paths.size() == 1 && o.methods.size() == 1) o.paths.clear();
  o.grid = r.b("grid");
  o.referenceSamples = r.i("reference_spp");
  o.imageSpp = r.i("image_spp");
  o.imagePaths = r.i("image_paths");
  o.progress = c.progress();
  o.cancel = c.ctx.cancel;
  const auto configs = studyConfigs(o);
  c.notice(
      format("study of %s: %zu configuration(s) at %dx%d texels, reference %d² paths per "
             "probe pair",
             scene.name.c_str(), configs.size(), o.nu, o.nv, o.referenceSamples));
  const std::string& dir = r.s("output");
  Comm& comm = c.ctx.processes();
  o.comm = &comm;
  if (comm.root()) makeFolder(dir);
  if (comm.distributed())
    c.notice(
        format("cluster job: %s; configuration i runs on rank i mod %d, each with %d "
               "thread(s): the times are theirs",
               comm.describe().c_str(), comm.size(), currentThreads()));
  const Study st = runStudy(scene, o);
  // Rank 0 writes the tables; the compression study runs over the ranks.
  if (!comm.root()) {
    if (!r.s("codecs").empty()) compressionStudy(c, scene, o, comm);
    return;
  }
  writeStudy(st, dir);
  std::string t = format("%-52s %9s %8s %8s %8s %7s\n", "configuration", "time", "interp.",
                         "at set", "image", "Pareto");
  StudyResult& out = c.rep.result.emplace<StudyResult>();
  out.scene = scene.name;
  out.output = dir;
  for (const auto& res : st.results) {
    t += format("%-52s %8.2fs %7.2f%% %7.2f%% %7.1f%% %7s\n", res.label().c_str(),
                res.seconds, 100 * res.probeRelRmse, 100 * res.setRelRmse, 100 * res.imageRelRmse,
                res.pareto ? "*" : "");
    out.configurations.push_back({res.label(), res.seconds, res.probeRelRmse,
                                  res.setRelRmse, res.imageRelRmse, res.pareto});
  }
  t += "wrote " + dir + "/study.csv, study.md, study.svg\n";
  c.rep.text = t;
  c.rep.summary =
      "wrote " + dir + "/study.csv (" + std::to_string(st.results.size()) + " configurations)";
  if (!r.s("codecs").empty()) compressionStudy(c, scene, o, comm);
}

}  // namespace btf::ops::detail
