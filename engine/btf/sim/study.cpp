#include <btf/core/error.h>
#include <btf/core/output_lock.h>
#include <btf/core/progress.h>
#include <btf/core/run_context.h>
#include <btf/core/sysinfo.h>
#include <btf/sim/path_tracer.h>
#include <btf/sim/simulator.h>
#include <btf/sim/study.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

namespace btf {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

void writeAtomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".partial";
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw Error(path + ": cannot write");
    f << text;
    if (!f) throw Error(path + ": write failed");
  }
  std::filesystem::rename(tmp, path);
}
}  // namespace

std::string StudyConfig::label() const {
  std::ostringstream s;
  if (method == "pt") {
    s << "pt " << dirs << " spp" << spp << " paths" << paths << " P" << bounces;
    return s.str();
  }
  s << dirs << (spp == 0 ? std::string(" adaptive") : " spp" + std::to_string(spp)) << " "
    << shadowModeName(shadows) << " P"
    << (bounces == 0 ? std::string("plan") : std::to_string(bounces));
  if (bounces != 1)
    s << " vox" << (voxels ? std::to_string(voxels) : "auto") << " N1=" << gather << " links"
      << links;
  return s.str();
}

std::vector<DirectionPair> studyProbePairs() {
  std::vector<DirectionPair> p;
  for (double ti : {0.0, 25.0, 50.0, 70.0})
    for (double to : {0.0, 30.0, 60.0})
      for (double po : {0.0, 90.0, 180.0}) {
        if (to == 0 && po != 0) continue;
        p.push_back(pairFromDegrees(ti, 0, to, po));
      }
  return p;
}

std::vector<StudyConfig> studyConfigs(const StudyOptions& o) {
  std::vector<StudyConfig> out{o.base};
  auto add = [&](const StudyConfig& c) {
    for (const auto& e : out)
      if (e.label() == c.label()) return;
    out.push_back(c);
  };
  if (!o.grid) {
    for (const auto& v : o.methods) {
      StudyConfig c = o.base;
      c.method = v;
      add(c);
    }
    for (int v : o.paths) {
      StudyConfig c = o.base;
      c.method = "pt";
      c.paths = v;
      add(c);
    }
    for (const auto& v : o.dirs) {
      StudyConfig c = o.base;
      c.dirs = v;
      add(c);
    }
    for (int v : o.spp) {
      StudyConfig c = o.base;
      c.spp = v;
      add(c);
    }
    for (ShadowMode v : o.shadows) {
      StudyConfig c = o.base;
      c.shadows = v;
      add(c);
    }
    for (int v : o.voxels) {
      StudyConfig c = o.base;
      c.voxels = v;
      add(c);
    }
    for (int v : o.gather) {
      StudyConfig c = o.base;
      c.gather = v;
      add(c);
    }
    for (int v : o.links) {
      StudyConfig c = o.base;
      c.links = v;
      add(c);
    }
    for (int v : o.bounces) {
      StudyConfig c = o.base;
      c.bounces = v;
      add(c);
    }
    return out;
  }
  auto orBase = [](auto list, auto base) {
    if (list.empty()) list.push_back(base);
    return list;
  };
  for (const auto& me : orBase(o.methods, o.base.method))
    for (const auto& d : orBase(o.dirs, o.base.dirs))
      for (int s : orBase(o.spp, o.base.spp))
        for (ShadowMode m : orBase(o.shadows, o.base.shadows))
          for (int v : orBase(o.voxels, o.base.voxels))
            for (int g : orBase(o.gather, o.base.gather))
              for (int l : orBase(o.links, o.base.links))
                for (int b : orBase(o.bounces, o.base.bounces))
                  for (int q : orBase(o.paths, o.base.paths))
                    add({me, d, s, m, v, g, l, b, me == "pt" ? q : 1});
  return out;
}

void markPareto(std::vector<StudyResult>& r) {
  for (auto& a : r) {
    a.pareto = true;
    for (const auto& b : r)
      if (&a != &b && b.seconds <= a.seconds && b.probeRelRmse <= a.probeRelRmse &&
          (b.seconds < a.seconds || b.probeRelRmse < a.probeRelRmse)) {
        a.pareto = false;
        break;
      }
  }
}

Study runStudy(const Scene& scene, const StudyOptions& o) {
  Study st;
  st.scene = scene.name;
  st.nu = o.nu;
  st.nv = o.nv;
  st.probes = studyProbePairs();
  st.imageProbes = {4, 12};  // (0,0 | 60,0 backscatter-ish) and (25,0 | 30,180)
  const auto configs = studyConfigs(o);

  // Reference: unbiased path tracing (unbounded paths) of the probes and of the image pairs.
  SimOptions base;
  base.nu = o.nu;
  base.nv = o.nv;
  base.progress = false;
  SimulationJob refJob(scene, base);
  const auto t0 = Clock::now();
  PathSettings ps;
  ps.maxBounces = 0;
  ps.seed = o.seed ^ 0x5eed;
  // In a cluster job every rank traces a share of each reference and all get the whole (the
  // bytes of one process).
  Comm& comm = o.comm ? *o.comm : localComm();
  {
    ProgressReporter pr("reference", 1, o.progress);
    st.reference = pathTracedBrdf(refJob.tracer(), refJob.materials(), st.probes,
                                  o.referenceSamples, 1, ps, o.cancel, &comm);
    pr.finish();
  }
  std::vector<std::vector<Rgb>> refImages;
  const SampleGrid refGrid{o.nu, o.nv, o.imageSpp, scene.Lx, scene.Ly, o.seed ^ 0x1a};
  for (int pi : st.imageProbes)
    refImages.push_back(pathTracedTexels(refJob.tracer(), refJob.materials(), refGrid,
                                         st.probes[size_t(pi)].wo, {st.probes[size_t(pi)].wi},
                                         o.imagePaths, ps, o.cancel, &comm));
  // Per direction set of the sweep, the probes snapped to the set's nearest directions and
  // their reference at exactly those directions.
  std::map<std::string, std::vector<Rgb>> setReference;
  for (const StudyConfig& c : configs) {
    if (setReference.count(c.dirs)) continue;
    SimOptions so = base;
    so.directions = c.dirs;
    const SimulationJob dj(scene, so);
    const DirectionSet& dirs = dj.directions();
    std::vector<DirectionPair> snapped;
    for (const auto& p : st.probes)
      snapped.push_back({dirs[dirs.nearest(p.wi)].w, dirs[dirs.nearest(p.wo)].w});
    setReference.emplace(c.dirs, pathTracedBrdf(refJob.tracer(), refJob.materials(), snapped,
                                                o.referenceSamples, 1, ps, o.cancel, &comm));
  }
  st.referenceSeconds = since(t0);
  double refSq = 0;
  for (const Rgb& r : st.reference) refSq += double(glm::dot(r, r));

  std::vector<size_t> mine;
  for (size_t i = size_t(comm.rank()); i < configs.size(); i += size_t(comm.size()))
    mine.push_back(i);
  ProgressReporter pr("study", int64_t(mine.size()), o.progress);
  // A failure in one rank's configurations fails every rank together (no collective inside).
  collectively(comm, [&] {
    for (const size_t ci : mine) {
      const StudyConfig& c = configs[ci];
      if (o.cancel && o.cancel->cancelled()) throw Cancelled("study");
      SimOptions so = base;
      so.method = c.method;
      so.ptPaths = c.paths;
      so.directions = c.dirs;
      // spp 0: adaptive sampling (the default); K > 0: uniform K×K. The path tracer is uniform.
      so.adaptive = c.spp == 0 && c.method != "pt";
      so.spp = std::max(1, c.spp);
      so.shadows = c.shadows;
      so.seed = o.seed;
      so.network.voxels = c.voxels;
      so.network.gather = c.gather;
      so.network.links = c.links;
      so.plan.selfShadowing = Toggle::On;
      // P = 0: what `simulate` does by default — the planner's effects, path length and tail.
      so.plan.interreflection = c.bounces == 0  ? Toggle::Auto
                                : c.bounces > 1 ? Toggle::On
                                                : Toggle::Off;
      so.plan.bounces = c.bounces > 1 ? c.bounces : 0;
      StudyResult res;
      res.config = c;
      const auto start = Clock::now();
      SimulationJob job(scene, so);
      res.visibility = job.visibilityName();
      job.plan();  // builds the network: part of the measured time
      const double planSeconds = since(start);
      // Sinks: the tile average of every (view, light) and the per-texel images of the probes.
      const DirectionSet& dirs = job.directions();
      const int n = dirs.size();
      std::vector<double> avg(size_t(n) * n * 3, 0.0);
      std::vector<std::vector<DirWeight>> wv(st.probes.size()), wl(st.probes.size());
      for (size_t p = 0; p < st.probes.size(); ++p) {
        const DVec3 a = st.probes[p].wo, b = st.probes[p].wi;
        wv[p] = dirs.interpolate(std::acos(std::clamp(a.z, -1.0, 1.0)), std::atan2(a.y, a.x));
        wl[p] = dirs.interpolate(std::acos(std::clamp(b.z, -1.0, 1.0)), std::atan2(b.y, b.x));
      }
      std::vector<std::vector<Rgb>> images(st.imageProbes.size(),
                                           std::vector<Rgb>(size_t(o.nu) * o.nv, Rgb(0)));
      job.setChunkSink([&](int, int64_t t0c, int64_t t1c, const float* v) {
        const size_t stride = size_t(n) * n * 3;
        for (int64_t t = t0c; t < t1c; ++t) {
          const float* m = v + size_t(t - t0c) * stride;
          for (size_t k = 0; k < stride; ++k) avg[k] += m[k];
          for (size_t q = 0; q < st.imageProbes.size(); ++q) {
            const size_t p = size_t(st.imageProbes[q]);
            Rgb x(0);
            for (const auto& a : wv[p])
              for (const auto& b : wl[p]) {
                const float* e = m + (size_t(a.index) * n + size_t(b.index)) * 3;
                x += float(a.weight * b.weight) * Rgb(e[0], e[1], e[2]);
              }
            images[q][size_t(t)] = x;
          }
        }
      });
      SimEstimate est = job.estimate("");
      const auto runStart = Clock::now();
      const SimReport rep = job.run("", est);
      res.seconds = planSeconds + since(runStart);
      res.precomputeSeconds = rep.precomputeSeconds;
      res.renderSeconds = rep.renderSeconds;
      res.networkPoints = rep.networkPoints;
      res.peakRssBytes = rep.peakRssBytes;
      const double invT = 1.0 / double(int64_t(o.nu) * o.nv);
      double errSq = 0;
      for (size_t p = 0; p < st.probes.size(); ++p) {
        Rgb x(0);
        for (const auto& a : wv[p])
          for (const auto& b : wl[p]) {
            const size_t k = (size_t(a.index) * n + size_t(b.index)) * 3;
            x += float(a.weight * b.weight * invT) * Rgb(avg[k], avg[k + 1], avg[k + 2]);
          }
        res.probeValues.push_back(x);
        const Rgb d = x - st.reference[p];
        errSq += double(glm::dot(d, d));
        const float r = std::max(st.reference[p].x, std::max(st.reference[p].y, st.reference[p].z));
        if (r > 1e-3f)
          for (int ch = 0; ch < 3; ++ch)
            if (st.reference[p][ch] > 1e-3f)
              res.probeMaxRel =
                  std::max(res.probeMaxRel, double(std::abs(d[ch]) / st.reference[p][ch]));
      }
      res.probeRelRmse = refSq > 0 ? std::sqrt(errSq / refSq) : std::sqrt(errSq);
      // Snapped probes: the nearest direction of the set for light and view, the BTF read without
      // interpolation, and the set's reference at exactly those directions (traced before the
      // sweep).
      std::vector<std::pair<int, int>> snappedIdx;
      for (const auto& pr0 : st.probes)
        snappedIdx.push_back({dirs.nearest(pr0.wi), dirs.nearest(pr0.wo)});
      const auto it = setReference.find(c.dirs);
      BTF_CHECK(it != setReference.end());
      double sErr = 0, sRef = 0;
      for (size_t p = 0; p < snappedIdx.size(); ++p) {
        const size_t k =
            (size_t(snappedIdx[p].second) * n + size_t(snappedIdx[p].first)) * 3;  // [view][light]
        const Rgb x = float(invT) * Rgb(avg[k], avg[k + 1], avg[k + 2]);
        res.setValues.push_back(x);
        res.setReference.push_back(it->second[p]);
        const Rgb d = x - it->second[p];
        sErr += double(glm::dot(d, d));
        sRef += double(glm::dot(it->second[p], it->second[p]));
      }
      res.setRelRmse = sRef > 0 ? std::sqrt(sErr / sRef) : std::sqrt(sErr);
      double iErr = 0, iRef = 0;
      for (size_t q = 0; q < images.size(); ++q)
        for (size_t t = 0; t < images[q].size(); ++t) {
          const Rgb d = images[q][t] - refImages[q][t];
          iErr += double(glm::dot(d, d));
          iRef += double(glm::dot(refImages[q][t], refImages[q][t]));
        }
      res.imageRelRmse = iRef > 0 ? std::sqrt(iErr / iRef) : std::sqrt(iErr);
      st.results.push_back(res);
      pr.add(1);
    }
  });
  pr.finish();
  if (comm.distributed()) {
    // Every rank's results to rank 0, back in configuration order.
    nlohmann::json mineJson = nlohmann::json::array();
    for (const StudyResult& res : st.results) {
      auto rgb = [](const std::vector<Rgb>& v) {
        std::vector<float> f;
        for (const Rgb& x : v) f.insert(f.end(), {x.x, x.y, x.z});
        return f;
      };
      mineJson.push_back({{"seconds", res.seconds},
                          {"precompute", res.precomputeSeconds},
                          {"render", res.renderSeconds},
                          {"probe", res.probeRelRmse},
                          {"set", res.setRelRmse},
                          {"probe_max", res.probeMaxRel},
                          {"image", res.imageRelRmse},
                          {"points", res.networkPoints},
                          {"rss", res.peakRssBytes},
                          {"visibility", res.visibility},
                          {"values", rgb(res.probeValues)},
                          {"set_values", rgb(res.setValues)},
                          {"set_reference", rgb(res.setReference)}});
    }
    const std::vector<std::string> all = comm.gather(mineJson.dump(), 0);
    st.results.clear();
    if (!comm.root()) return st;
    std::vector<StudyResult> ordered(configs.size());
    for (int q = 0; q < comm.size(); ++q) {
      const nlohmann::json arr = nlohmann::json::parse(all[size_t(q)]);
      size_t i = size_t(q);
      for (const auto& j : arr) {
        StudyResult& res = ordered[i];
        res.config = configs[i];
        res.seconds = j["seconds"];
        res.precomputeSeconds = j["precompute"];
        res.renderSeconds = j["render"];
        res.probeRelRmse = j["probe"];
        res.setRelRmse = j["set"];
        res.probeMaxRel = j["probe_max"];
        res.imageRelRmse = j["image"];
        res.networkPoints = j["points"];
        res.peakRssBytes = j["rss"];
        res.visibility = j["visibility"];
        auto rgb = [](const nlohmann::json& a) {
          const std::vector<float> f = a.get<std::vector<float>>();
          std::vector<Rgb> v;
          for (size_t k = 0; k + 2 < f.size(); k += 3) v.emplace_back(f[k], f[k + 1], f[k + 2]);
          return v;
        };
        res.probeValues = rgb(j["values"]);
        res.setValues = rgb(j["set_values"]);
        res.setReference = rgb(j["set_reference"]);
        i += size_t(comm.size());
      }
    }
    st.results = std::move(ordered);
  }
  markPareto(st.results);
  return st;
}

std::vector<StudyRow> parseStudyCsv(const std::string& text, const std::string& source) {
  // Fields split at commas outside double quotes; quotes removed.
  auto fields = [](const std::string& line) {
    std::vector<std::string> v(1);
    bool quoted = false;
    for (char ch : line) {
      if (ch == '"')
        quoted = !quoted;
      else if (ch == ',' && !quoted)
        v.emplace_back();
      else if (ch != '\r')
        v.back() += ch;
    }
    return v;
  };
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line)) throw Error(source + ": empty study table (no header line)");
  const std::vector<std::string> head = fields(line);
  auto col = [&](const char* n) {
    for (size_t i = 0; i < head.size(); ++i)
      if (head[i] == n) return i;
    throw Error(source + ":1: no column '" + n + "'");
  };
  const size_t cl = col("config"), cd = col("dirs"), cq = col("spp"), cs = col("seconds"),
               ce = col("probe_rel_rmse"), cp = col("pareto");
  const size_t need = std::max({cl, cd, cq, cs, ce, cp}) + 1;
  std::vector<StudyRow> rows;
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = source + ":" + std::to_string(n);
    if (rows.size() == 100000) throw Error(where + ": more than 100000 rows");
    const std::vector<std::string> v = fields(line);
    if (v.size() < need)
      throw Error(where + ": " + std::to_string(v.size()) + " fields, the header names " +
                  std::to_string(head.size()));
    auto number = [&](size_t c, const char* name) {
      const std::string& t = v[c];
      char* end = nullptr;
      const double x = t.empty() ? NAN : std::strtod(t.c_str(), &end);
      if (t.empty() || end != t.c_str() + t.size() || !std::isfinite(x) || x < 0)
        throw Error(where + ": column '" + name + "' must be a finite number >= 0 (got '" +
                    t.substr(0, 32) + "')");
      return x;
    };
    StudyRow r;
    r.config = v[cl].substr(0, 256);
    r.dirs = v[cd].substr(0, 64);
    const double spp = number(cq, "spp");
    if (spp != std::floor(spp) || spp > 4096)
      throw Error(where + ": column 'spp' must be an integer in 0..4096");
    r.spp = int(spp);
    r.seconds = number(cs, "seconds");
    r.error = number(ce, "probe_rel_rmse");
    if (v[cp] != "0" && v[cp] != "1") throw Error(where + ": column 'pareto' must be 0 or 1");
    r.pareto = v[cp] == "1";
    rows.push_back(std::move(r));
  }
  return rows;
}

void writeStudy(const Study& s, const std::string& dir) {
  makeFolder(dir);
  std::ostringstream csv;
  csv << "config,dirs,spp,shadows,bounces,voxels,gather,links,seconds,precompute_seconds,"
         "render_seconds,network_points,probe_rel_rmse,set_rel_rmse,probe_max_rel,image_rel_rmse,"
         "peak_rss_"
         "bytes,pareto\n";
  for (const auto& r : s.results) {
    const auto& c = r.config;
    char line[512];
    std::snprintf(line, sizeof line,
                  "\"%s\",%s,%d,%s,%d,%d,%d,%d,%.4f,%.4f,%.4f,%zu,%.6f,%.6f,%.6f,%.6f,%llu,%d\n",
                  r.label().c_str(), c.dirs.c_str(), c.spp, shadowModeName(c.shadows), c.bounces,
                  c.voxels, c.gather, c.links, r.seconds, r.precomputeSeconds, r.renderSeconds,
                  r.networkPoints, r.probeRelRmse, r.setRelRmse, r.probeMaxRel, r.imageRelRmse,
                  (unsigned long long)r.peakRssBytes, r.pareto ? 1 : 0);
    csv << line;
  }
  writeAtomic(dir + "/study.csv", csv.str());
  std::ostringstream pc;
  pc << "config,probe,theta_i,phi_i,theta_o,phi_o,ref_r,ref_g,ref_b,r,g,b\n";
  for (const auto& r : s.results)
    for (size_t p = 0; p < s.probes.size() && p < r.probeValues.size(); ++p) {
      const DVec3 a = s.probes[p].wi, b = s.probes[p].wo;
      char line[400];
      std::snprintf(line, sizeof line,
                    "\"%s\",%zu,%.1f,%.1f,%.1f,%.1f,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n",
                    r.label().c_str(), p, rad2deg(std::acos(a.z)),
                    rad2deg(std::atan2(a.y, a.x)), rad2deg(std::acos(b.z)),
                    rad2deg(std::atan2(b.y, b.x)), s.reference[p].x, s.reference[p].y,
                    s.reference[p].z, r.probeValues[p].x, r.probeValues[p].y, r.probeValues[p].z);
      pc << line;
    }
  writeAtomic(dir + "/probes.csv", pc.str());

  std::ostringstream md;
  md << "Study of `" << s.scene << "` at " << s.nu << "×" << s.nv << " texels; reference: path "
     << "tracing with unbounded paths (" << s.probes.size() << " probe pairs, "
     << formatSeconds(s.referenceSeconds) << ").\n\n"
     << "Columns: *interp.* = relative RMSE of the texel-averaged aBRDF interpolated at the fixed "
        "probes (what a renderer sees: simulation + direction discretisation); *at set* = the same "
        "with each probe snapped to the set's nearest directions and its own reference (the "
        "simulation's error alone); *worst* = worst probe channel, interpolated; *image* = "
        "per-texel relative RMSE of two full images. Pareto: on time vs interp. error.\n\n"
     << "| configuration | time | precompute | render | network points | interp. rel. RMSE | "
        "at set rel. RMSE | worst | image rel. RMSE | Pareto |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : s.results) {
    char line[512];
    std::snprintf(
        line, sizeof line,
        "| %s | %.2f s | %.2f s | %.2f s | %zu | %.2f %% | %.2f %% | %.1f %% | %.1f %% | %s |\n",
        r.label().c_str(), r.seconds, r.precomputeSeconds, r.renderSeconds, r.networkPoints,
        100 * r.probeRelRmse, 100 * r.setRelRmse, 100 * r.probeMaxRel, 100 * r.imageRelRmse,
        r.pareto ? "●" : "");
    md << line;
  }
  writeAtomic(dir + "/study.md", md.str());

  // SVG: log-log error vs time, Pareto front joined.
  const double W = 720, H = 480, L = 70, R = 20, T = 30, B = 60;
  double tmin = 1e30, tmax = 0, emin = 1e30, emax = 0;
  for (const auto& r : s.results) {
    tmin = std::min(tmin, std::max(r.seconds, 1e-3));
    tmax = std::max(tmax, std::max(r.seconds, 1e-3));
    emin = std::min(emin, std::max(r.probeRelRmse, 1e-5));
    emax = std::max(emax, std::max(r.probeRelRmse, 1e-5));
  }
  const double lt0 = std::floor(std::log10(tmin)), lt1 = std::ceil(std::log10(tmax) + 1e-9);
  const double le0 = std::floor(std::log10(emin)), le1 = std::ceil(std::log10(emax) + 1e-9);
  auto X = [&](double t) {
    return L + (std::log10(std::max(t, 1e-3)) - lt0) / std::max(lt1 - lt0, 1.0) * (W - L - R);
  };
  auto Y = [&](double e) {
    return H - B - (std::log10(std::max(e, 1e-5)) - le0) / std::max(le1 - le0, 1.0) * (H - T - B);
  };
  std::ostringstream svg;
  svg << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
      << "' font-family='sans-serif' font-size='11'>\n<rect width='100%' height='100%' "
         "fill='white'/>\n";
  svg << "<text x='" << W / 2 << "' y='18' text-anchor='middle' font-size='13'>" << s.scene
      << ": probe relative RMSE vs wall time (" << s.nu << "×" << s.nv
      << " texels; ● Pareto front)</text>\n";
  for (double k = lt0; k <= lt1; ++k)
    svg << "<line x1='" << X(std::pow(10, k)) << "' y1='" << T << "' x2='" << X(std::pow(10, k))
        << "' y2='" << H - B << "' stroke='#ddd'/><text x='" << X(std::pow(10, k)) << "' y='"
        << H - B + 16 << "' text-anchor='middle'>" << std::pow(10, k) << " s</text>\n";
  for (double k = le0; k <= le1; ++k)
    svg << "<line x1='" << L << "' y1='" << Y(std::pow(10, k)) << "' x2='" << W - R << "' y2='"
        << Y(std::pow(10, k)) << "' stroke='#ddd'/><text x='" << L - 6 << "' y='"
        << Y(std::pow(10, k)) + 4 << "' text-anchor='end'>" << 100 * std::pow(10, k)
        << " %</text>\n";
  svg << "<text x='" << W / 2 << "' y='" << H - 20 << "' text-anchor='middle'>wall time</text>\n";
  std::vector<const StudyResult*> front;
  for (const auto& r : s.results)
    if (r.pareto) front.push_back(&r);
  std::sort(front.begin(), front.end(),
            [](const StudyResult* a, const StudyResult* b) { return a->seconds < b->seconds; });
  if (front.size() > 1) {
    svg << "<polyline fill='none' stroke='#d33' stroke-width='1.5' points='";
    for (const auto* r : front) svg << X(r->seconds) << "," << Y(r->probeRelRmse) << " ";
    svg << "'/>\n";
  }
  for (const auto& r : s.results) {
    svg << "<circle cx='" << X(r.seconds) << "' cy='" << Y(r.probeRelRmse) << "' r='4' fill='"
        << (r.pareto ? "#d33" : "#4a7") << "'><title>" << r.label() << "</title></circle>"
        << "<text x='" << X(r.seconds) + 6 << "' y='" << Y(r.probeRelRmse) - 5
        << "' font-size='9' fill='#555'>" << r.label() << "</text>\n";
  }
  svg << "</svg>\n";
  writeAtomic(dir + "/study.svg", svg.str());
}

}  // namespace btf
