// The front of the use-case floor: validation, the per-run thread arena, and the one outcome of
// a cancel (no output, no .partial left unless the caller keeps it for a resume).
#include <btf/compress/codec.h>
#include <btf/core/output_lock.h>
#include <btf/core/sysinfo.h>
#include <btf/ops/internal.h>
#include <btf/scene/scene.h>
#include <btf/sim/simulator.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <sstream>

namespace btf::ops {

namespace fs = std::filesystem;

namespace detail {

std::vector<std::string> splitList(const std::string& s, const std::string& what) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  if (out.empty()) throw Error(what + ": empty list");
  return out;
}

std::vector<int> intList(const std::string& s, const std::string& what, int lo, int hi) {
  std::vector<int> out;
  for (const auto& t : splitList(s, what)) {
    char* end = nullptr;
    const long v = std::strtol(t.c_str(), &end, 10);
    if (*end || v < lo || v > hi)
      throw Error(what + ": value '" + t + "' must be an integer in " + std::to_string(lo) + ".." +
                  std::to_string(hi));
    out.push_back(int(v));
  }
  return out;
}

}  // namespace detail

void parseTexels(const std::string& s, int* nu, int* nv, const std::string& option) {
  int a = 0, b = 0;
  char x = 0, extra = 0;
  const int n = std::sscanf(s.c_str(), "%d%c%d%c", &a, &x, &b, &extra);
  if (n == 1)
    b = a;
  else if (!(n == 3 && (x == 'x' || x == 'X')))
    throw Error("invalid " + option + " '" + s + "': expected N or NUxNV, e.g. 64 or 64x32");
  if (a < 1 || b < 1 || a > 16384 || b > 16384)
    throw Error("invalid " + option + " '" + s + "': each count must be between 1 and 16384");
  *nu = a;
  *nv = b;
}

void parseAnglePair(const std::string& s, const std::string& what, double* theta, double* phi,
                    double maxTheta) {
  std::istringstream in(s);
  char comma = 0;
  std::string rest;
  if (!(in >> *theta >> comma >> *phi) || comma != ',' || (in >> rest))
    throw Error("invalid " + what + " '" + s + "': expected θ,φ in degrees, e.g. 30,45");
  const bool wide = maxTheta > 90;  // around an object: [0, 180]; a BTF direction: [0, 90)
  if (!std::isfinite(*theta) || !std::isfinite(*phi) || *theta < 0 ||
      (wide ? *theta > 180 : *theta >= 90))
    throw Error("invalid " + what + " '" + s + "': θ must be in " +
                (wide ? "[0, 180]" : "[0, 90)") + " degrees");
}

namespace {

Toggle toggle(const Request& r, const std::string& k) {
  return parseToggle(r.s(k), optionName(r.decl(), k));
}

}  // namespace

SimOptions simOptions(const Scene& scene, const Request& r) {
  SimOptions o = optionsFromScene(scene);
  if (r.has("texels") && !r.s("texels").empty()) parseTexels(r.s("texels"), &o.nu, &o.nv);
  if (r.has("dirs") && !r.s("dirs").empty()) o.directions = r.s("dirs");
  if (r.has("spp")) o.spp = r.i("spp");
  // --sampling decides; else --spp K alone asks for uniform K×K, the reference mode.
  if (r.given("sampling"))
    o.adaptive = r.s("sampling") == "adaptive";
  else if (r.given("spp"))
    o.adaptive = false;
  if (r.given("max_spp")) o.adaptiveSettings.maxK = r.i("max_spp");
  if (r.has("tolerance")) o.adaptiveSettings.tolerance = float(r.f("tolerance"));
  if (r.has("edge_cells")) o.adaptiveSettings.edgeCells = r.b("edge_cells");
  if (r.has("shadows") && r.s("shadows").find(',') == std::string::npos)
    o.shadows = parseShadowMode(r.s("shadows"));
  if (r.has("seed")) o.seed = uint64_t(r.i("seed"));
  if (r.has("bias")) o.shadowBias = float(r.f("bias"));
  if (r.has("method")) o.method = r.s("method");
  if (r.decl().find("self_shadowing")) {
    o.plan.selfShadowing = toggle(r, "self_shadowing");
    if (r.given("interreflection")) o.plan.interreflection = toggle(r, "interreflection");
    o.plan.colour = toggle(r, "colour");
    o.plan.glossyIndirect = toggle(r, "glossy_indirect");
    {
      const std::string t = r.s("tail");
      o.plan.tail = t == "add" ? Toggle::On : t == "drop" ? Toggle::Off : Toggle::Auto;
    }
    o.plan.vmf = toggle(r, "vmf");
    const int bounces = r.i("bounces");
    if (bounces > 0) {
      o.plan.bounces = bounces;
      if (bounces > 1 && o.plan.interreflection == Toggle::Auto)
        o.plan.interreflection = Toggle::On;
      if (bounces == 1) o.plan.interreflection = Toggle::Off;
    }
    o.plan.epsilon = r.f("epsilon");
    o.grazingRays = r.f("grazing_rays");
    if (r.has("visibility")) o.visibility = r.s("visibility");
    o.grazingRaysForced = r.given("grazing_rays");
    const int voxels = r.i("network_voxels");
    if (voxels == 1) throw Error("--network-voxels: must be 0 (one per texel) or in 2..1024");
    if (voxels != 0) o.network.voxels = voxels;
    o.network.links = r.i("links");
    o.network.gather = r.i("gather");
    o.network.gatherOcclusion = r.i("gather_occlusion");
    o.reciprocalGather = r.s("reciprocal_gather") == "on";
    o.ptPaths = r.i("paths");
  }
  if (r.has("chunk_texels")) o.maxChunkTexels = r.i("chunk_texels");
  if (r.has("memory_budget")) o.memoryBudget = parseBytes(r.s("memory_budget"));
  if (r.has("resume")) o.resume = r.b("resume");
  return o;
}

CodecSettings codecSettings(const Request& r, const std::string& codec) {
  CodecSettings s;
  s.codec = codec;
  s.colour = r.s("colour_model");
  s.components = r.has("components") && r.decl().find("components")->type == ParamType::Int
                     ? r.i("components")
                     : 0;
  s.targetRmse = r.f("target_rmse");
  s.targetRatio = r.f("target_ratio");
  if (r.has("beta")) {
    s.beta = r.f("beta");
    s.betaMode = la::betaModeFromName(r.s("beta_mode"));
    s.solver = la::nmfSolverFromName(r.s("solver"));
    s.maxRank = r.i("max_rank");
    s.nmfIterations = r.i("nmf_iterations");
    s.trainTexels = r.i("train_texels");
    s.clusters = r.i("clusters");
    s.halfway = r.b("halfway");
    s.neuralHidden = r.i("hidden");
    s.neuralLayers = r.i("hidden_layers");
    s.neuralSteps = r.i("neural_steps");
    s.neuralRate = r.f("learning_rate");
    s.neuralEncoding = r.s("encoding");
    s.half = !r.b("f32");
  }
  validate(s);
  return s;
}

Report run(const Request& r, const RunContext& ctx) {
  return run(r, ctx, nullptr);
}

Scene detail::Call::scene() const {
  return preloaded ? *preloaded : loadScene(r.s("scene"));
}

Report run(const Request& r, const RunContext& ctxIn, const NoteSink& notes, const Scene* scene) {
  r.validate();
  RunContext ctx = ctxIn;
  if (r.given("threads")) ctx.threads = r.i("threads");
  // A cluster job (docs/cluster.md) spreads simulate, compress, compare and study over its ranks;
  // any other command runs on rank 0 alone while the others wait for it.
  static const std::set<std::string> kDistributed = {"simulate", "compress", "compare", "study"};
  if (ctx.processes().distributed() && !kDistributed.count(r.command())) {
    Comm& comm = ctx.processes();
    Report rep;
    rep.command = r.command();
    collectively(comm, [&] {
      if (!comm.root()) return;
      RunContext alone = ctxIn;
      alone.comm = nullptr;
      rep = run(r, alone, notes, scene);
    });
    return rep;
  }
  Report rep;
  rep.command = r.command();
  const detail::Call c{r, ctx, notes, rep, scene};
  // What this run may leave behind when it is cancelled: its output (and the .partial).
  const std::string out = r.has("output") ? r.s("output") : std::string();
  const bool outExisted = !out.empty() && fs::exists(out);
  // Outputs are checked and locked before any work: one writer per output.
  const bool folderOut = r.command() == "study" ||
                         (r.command() == "export" && r.s("format") == "ubo2003" && !r.b("zip"));
  std::unique_ptr<OutputLock> lock;
  collectively(ctx.processes(), [&] {
    if (!out.empty()) {
      checkOutputPath(out, folderOut);
      // In a cluster job rank 0 holds the lock and makes the folder for the job's ranks.
      if (!folderOut && ctx.processes().root()) lock = std::make_unique<OutputLock>(out);
      // A folder output is made now, so a folder that cannot be written is refused before work.
      if (folderOut && ctx.processes().root()) makeFolder(out);
    }
  });
  // A failed run leaves no output it began (an export's folder); a simulation keeps its
  // .partial for --resume.
  auto cleanUp = [&] {
    std::error_code ec;
    if (!out.empty() && !outExisted && ctx.processes().root()) fs::remove_all(out, ec);
  };
  try {
    withThreads(ctx.threads, [&] {
      const std::string& n = r.command();
      if (n == "simulate") return detail::simulate(c);
      if (n == "plan") return detail::plan(c);
      if (n == "bench") return detail::bench(c);
      if (n == "brdf") return detail::brdf(c);
      if (n == "compress") return detail::compress(c);
      if (n == "compare") return detail::compare(c);
      if (n == "export") return detail::exportBtf(c);
      if (n == "info") return detail::info(c);
      if (n == "slice") return detail::slice(c);
      if (n == "render") return detail::render(c);
      if (n == "study") return detail::study(c);
      throw Error("command '" + n + "' has no use case");
    });
  } catch (const Cancelled&) {
    if (!out.empty()) {
      std::error_code ec;
      if (!ctx.keepPartial) fs::remove(out + ".partial", ec);
      if (!outExisted) fs::remove_all(out, ec);
    }
    throw;
  } catch (const std::filesystem::filesystem_error& e) {
    // The standard library's text ("filesystem error: cannot create directories: …") in ours.
    cleanUp();
    throw Error((e.path1().empty() ? r.command() : e.path1().string()) + ": " + e.code().message());
  } catch (const std::bad_alloc&) {
    cleanUp();
    throw Error(r.command() +
                ": out of memory: this machine could not allocate what the run needs (lower its "
                "size, or --memory-budget so it is refused with the figures before it starts)");
  } catch (...) {
    cleanUp();
    throw;
  }
  rep.json = toJson(rep.result);
  rep.json["request"] = nlohmann::ordered_json::parse(r.toJson())["options"];
  return rep;
}

}  // namespace btf::ops
