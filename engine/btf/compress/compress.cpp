#include "compress.h"

#include <btf/core/error.h>
#include <btf/core/output_lock.h>
#include <btf/core/progress.h>
#include <btf/core/run_context.h>
#include <btf/core/sysinfo.h>
#include <btf/io/image_io.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>

namespace btf {
namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
}  // namespace

CompressedBtf Encoder::finishOn(Comm& comm) {
  if (!comm.distributed()) return finish();
  const std::vector<std::string> states = comm.gather(addedState(), 0);
  if (!comm.root()) return CompressedBtf{};
  for (int q = 1; q < comm.size(); ++q) mergeAdded(states[size_t(q)]);
  return finish();
}

CompressedBtf compressStore(const std::string& inPath, const CodecSettings& s, bool progress,
                            const CancelToken* cancel, CompressReport* report, Comm* commIn) {
  Comm& comm = commIn ? *commIn : localComm();
  const uint64_t comm0 = comm.bytesSent() + comm.bytesReceived();
  const auto start = Clock::now();
  std::unique_ptr<BtfReader> reader;
  std::unique_ptr<Encoder> enc;
  CompressedBtf vmfOnly;  // the coded visibility map alone
  CompressReport r;
  // In a cluster job every rank reaches each agreement, even when its own share failed.
  collectively(comm, [&] {
    reader = std::make_unique<BtfReader>(inPath);
    const BtfReader& in = *reader;
    const BtfInfo& info = in.info();
    enc = makeEncoder(s, info, cancel);
    enc->setProgress(progress);
    // The visibility map goes into the file beside the arrays: coded first, so that a
    // --target-ratio budget leaves its bytes out (every rank reads it: the same budget).
    if (info.hasVmf) {
      vmfOnly.info = info;
      vmfOnly.setVmf(in.readVmfAll());
      enc->reserveBytes(vmfOnly.vmfCoded.size());
    }
    r.texels = info.texels();
    r.texelBytes = double(info.texelBytes());
    const auto train = enc->trainingTexels();
    const size_t stride = size_t(info.nDirs()) * info.nDirs() * 3;
    if (s.memoryBudget > 0) {
      const double encoder = double(enc->memoryBytes());
      const double training = double(train.size()) * double(info.texelBytes());
      const double chunk = double(info.chunkTexels) * double(info.texelBytes());
      if (encoder + training + chunk > double(s.memoryBudget))
        throw Error("refusing to start: compressing " + inPath + " with " + s.codec +
                    " needs about " + formatBytes(encoder + training + chunk) + " (encoder " +
                    formatBytes(encoder) + ", training texels " + formatBytes(training) +
                    ", one chunk " + formatBytes(chunk) + ") but the memory budget is " +
                    formatBytes(double(s.memoryBudget)) +
                    "; lower --train-texels or --max-rank, or raise --memory-budget");
    }
    if (!train.empty()) {
      const auto t0 = Clock::now();
      std::vector<float> values(train.size() * stride);
      ProgressReporter pr("training read", int64_t(train.size()), progress);
      for (size_t i = 0; i < train.size(); ++i) {
        in.readTexelInto(train[i], values.data() + i * stride);
        pr.add(1);
      }
      pr.finish();
      enc->train(values.data());
      r.trainSeconds = since(t0);
    }
    {
      const auto t0 = Clock::now();
      // A cluster job: chunk c is rank c mod N's.
      int64_t mine = 0;
      for (int c = comm.rank(); c < info.chunks(); c += comm.size())
        mine += info.chunkEnd(c) - info.chunkBegin(c);
      ProgressReporter pr("encode " + s.codec, mine, progress);
      for (int c = comm.rank(); c < info.chunks(); c += comm.size()) {
        if (cancel && cancel->cancelled()) throw Cancelled("compression");
        const std::vector<float> chunk = in.readChunk(c);
        enc->add(info.chunkBegin(c), info.chunkEnd(c), chunk.data());
        pr.add(info.chunkEnd(c) - info.chunkBegin(c));
      }
      r.texelsEncoded = mine;
      if (cancel && cancel->cancelled()) throw Cancelled("compression");
      pr.finish();
      r.encodeSeconds = since(t0);
    }
  });
  const auto f0 = Clock::now();
  CompressedBtf out;
  r.ranks = comm.size();
  out = enc->finishOn(comm);  // holds collectives: never inside collectively()
  r.commBytes = comm.bytesSent() + comm.bytesReceived() - comm0;
  if (!comm.root()) {
    r.seconds = since(start);
    if (report) *report = r;
    return out;
  }
  r.finishSeconds = since(f0);
  out.copyVmf(vmfOnly);  // the file is self-sufficient
  finishReport(&r, out, since(start));
  if (report) *report = r;
  return out;
}

void finishReport(CompressReport* r, const CompressedBtf& out, double seconds) {
  r->seconds = seconds;
  r->peakRssBytes = peakRssBytes();
  r->fileBytes = out.fileBytes();
  r->ratio = out.ratio();
}

ErrorReport compareBtfs(const Decoder& ref, const Decoder& test, bool progress, int worst,
                        const CancelToken* cancel, Comm* commIn) {
  Comm& comm = commIn ? *commIn : localComm();
  const BtfInfo& a = ref.info();
  const BtfInfo& b = test.info();
  if (a.nu != b.nu || a.nv != b.nv)
    throw Error("compare: texel grids differ (" + std::to_string(a.nu) + "×" +
                std::to_string(a.nv) + " vs " + std::to_string(b.nu) + "×" + std::to_string(b.nv) +
                ")");
  if (a.dirsDeg != b.dirsDeg)
    throw Error("compare: direction sets differ ('" + a.directionSet + "' vs '" + b.directionSet +
                "')");
  ErrorReport r;
  r.nu = a.nu;
  r.nv = a.nv;
  r.nDirs = a.nDirs();
  const int64_t T = a.texels();
  const size_t lv = size_t(r.nDirs) * r.nDirs;
  r.texelRmse.assign(size_t(T), 0.f);
  std::vector<double> dirSum(lv, 0.0);
  double sumErr = 0, sumRef = 0, peak = 0, maxAbs = 0;
  std::mutex mutex;
  // This rank's texels: a contiguous share.
  const int64_t lo = T * comm.rank() / comm.size(), hi = T * (comm.rank() + 1) / comm.size();
  ProgressReporter pr("compare", hi - lo, progress);
  std::vector<double> texSe(size_t(hi - lo), 0.0), texSr(size_t(hi - lo), 0.0);
  // A damaged chunk in one rank's share fails every rank together (no collective inside).
  collectively(comm, [&] {
    parallelForChunks(
        hi - lo, 8,
        [&](int64_t b0, int64_t b1) {
          const int64_t t0 = lo + b0, t1 = lo + b1;
          std::vector<float> x(lv * 3), y(lv * 3);
          std::vector<double> dirs(lv, 0.0);
          double pk = 0, mx = 0;
          for (int64_t t = t0; t < t1; ++t) {
            ref.texel(t, x.data());
            test.texel(t, y.data());
            double te = 0, tr = 0;
            for (size_t k = 0; k < lv; ++k) {
              double de = 0;
              for (int c = 0; c < 3; ++c) {
                const double xv = x[k * 3 + size_t(c)], d = xv - y[k * 3 + size_t(c)];
                de += d * d;
                tr += xv * xv;
                pk = std::max(pk, xv);
                mx = std::max(mx, std::abs(d));
              }
              dirs[k] += de;
              te += de;
            }
            texSe[size_t(t - lo)] = te;
            texSr[size_t(t - lo)] = tr;
            r.texelRmse[size_t(t)] = float(std::sqrt(te / double(lv * 3)));
            pr.add(1);
          }
          std::lock_guard<std::mutex> lock(mutex);
          for (size_t k = 0; k < lv; ++k) dirSum[k] += dirs[k];
          peak = std::max(peak, pk);
          maxAbs = std::max(maxAbs, mx);
        },
        cancel);
    if (cancel && cancel->cancelled()) throw Cancelled("compare");
    // The totals in texel order, whatever the threads' chunks: the same bytes every run (a
    // pyramid's header holds them).
    for (size_t k = 0; k < texSe.size(); ++k) sumErr += texSe[k], sumRef += texSr[k];
  });
  pr.finish();
  if (comm.distributed()) {
    // Sums in rank order; the per-texel errors of every share.
    std::vector<double> sums = dirSum;
    sums.push_back(sumErr);
    sums.push_back(sumRef);
    sums = sumInRankOrder(comm, sums);
    sumErr = sums[lv];
    sumRef = sums[lv + 1];
    sums.resize(lv);
    dirSum = sums;
    std::vector<double> mx = {peak, maxAbs};
    for (const std::string& s : comm.allgather(packDoubles(mx))) {
      const std::vector<double> v = unpackDoubles(s);
      peak = std::max(peak, v[0]);
      maxAbs = std::max(maxAbs, v[1]);
    }
    const std::vector<std::string> all = comm.allgather(std::string(
        reinterpret_cast<const char*>(r.texelRmse.data() + lo), size_t(hi - lo) * sizeof(float)));
    for (int q = 0; q < comm.size(); ++q) {
      const int64_t a = T * q / comm.size();
      std::memcpy(r.texelRmse.data() + a, all[size_t(q)].data(), all[size_t(q)].size());
    }
  }
  r.values = T * int64_t(lv) * 3;
  r.rmse = std::sqrt(sumErr / double(r.values));
  r.refRms = std::sqrt(sumRef / double(r.values));
  r.relRmse = r.refRms > 0 ? r.rmse / r.refRms : (r.rmse > 0 ? 1.0 : 0.0);
  r.peak = peak;
  r.maxAbs = maxAbs;
  r.psnr = r.rmse > 0 && peak > 0 ? 20.0 * std::log10(peak / r.rmse) : 999.0;
  r.dirRmse.resize(lv);
  for (size_t k = 0; k < lv; ++k) r.dirRmse[k] = float(std::sqrt(dirSum[k] / double(T * 3)));
  auto topOf = [worst](const std::vector<float>& v) {
    std::vector<int64_t> idx(v.size());
    for (size_t i = 0; i < v.size(); ++i) idx[i] = int64_t(i);
    const size_t n = std::min(v.size(), size_t(std::max(worst, 0)));
    std::partial_sort(idx.begin(), idx.begin() + long(n), idx.end(),
                      [&](int64_t p, int64_t q) { return v[size_t(p)] > v[size_t(q)]; });
    std::vector<ErrorReport::Worst> out;
    for (size_t i = 0; i < n; ++i) out.push_back({idx[i], v[size_t(idx[i])]});
    return out;
  };
  r.worstTexels = topOf(r.texelRmse);
  r.worstDirections = topOf(r.dirRmse);
  return r;
}

void writeErrorMaps(const ErrorReport& r, const std::string& dir) {
  makeFolder(dir);
  auto write = [&](const std::string& name, int w, int h, const std::vector<float>& v) {
    std::vector<float> rgb(v.size() * 3);
    float mx = 0;
    for (size_t i = 0; i < v.size(); ++i) {
      rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = v[i];
      mx = std::max(mx, v[i]);
    }
    writeRgbImage(dir + "/" + name + ".exr", w, h, rgb, 1.0f, true,
                  {{"units", "RMSE of the aBRDF, 1/sr (grey)"},
                   {"map", name == "texel_rmse" ? "per texel: columns u, rows v (v up)"
                                                : "per direction pair: columns light, rows view"},
                   {"peak", std::to_string(r.peak)}});
    writeRgbImage(dir + "/" + name + ".png", w, h, rgb, mx > 0 ? 1.f / mx : 1.f);
  };
  write("texel_rmse", r.nu, r.nv, r.texelRmse);
  write("direction_rmse", r.nDirs, r.nDirs, r.dirRmse);
}

std::string errorReportJson(const ErrorReport& r) {
  nlohmann::ordered_json j;
  j["values"] = r.values;
  j["rmse"] = r.rmse;
  j["relative_rmse"] = r.relRmse;
  j["psnr_db"] = r.psnr;
  j["peak"] = r.peak;
  j["reference_rms"] = r.refRms;
  j["max_abs_error"] = r.maxAbs;
  auto list = [&](const std::vector<ErrorReport::Worst>& w, bool texel) {
    nlohmann::ordered_json a = nlohmann::ordered_json::array();
    for (const auto& x : w) {
      nlohmann::ordered_json e;
      if (texel) {
        e["u"] = x.index % r.nu;
        e["v"] = x.index / r.nu;
      } else {
        e["view"] = x.index / r.nDirs;
        e["light"] = x.index % r.nDirs;
      }
      e["rmse"] = x.rmse;
      a.push_back(e);
    }
    return a;
  };
  j["worst_texels"] = list(r.worstTexels, true);
  j["worst_directions"] = list(r.worstDirections, false);
  return j.dump(1);
}

}  // namespace btf
