#include <btf/compress/mip.h>
#include <btf/core/error.h>
#include <btf/core/format.h>
#include <btf/core/progress.h>
#include <btf/core/run_context.h>
#include <btf/core/sysinfo.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

namespace btf {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

size_t strideOf(const BtfInfo& I) {
  return size_t(I.nDirs()) * size_t(I.nDirs()) * 3;
}

// A level's texels in memory: a window of a shared buffer (the coarse levels of a pyramid are
// built once and every level decoder reads its part).
class MemoryLevel final : public Decoder {
 public:
  MemoryLevel(BtfInfo info, std::shared_ptr<const std::vector<float>> data, size_t offset,
              std::string kind)
      : Decoder(std::move(info)),
        m_data(std::move(data)),
        m_offset(offset),
        m_stride(strideOf(m_info)),
        m_kind(std::move(kind)) {
    if (m_offset + size_t(m_info.texels()) * m_stride > m_data->size())
      throw Error("a texel level outside its buffer");
  }
  void texel(int64_t t, float* out) const override {
    check(t);
    const float* p = m_data->data() + m_offset + size_t(t) * m_stride;
    std::copy(p, p + m_stride, out);
  }
  std::array<float, 3> value(int64_t t, int view, int light) const override {
    check(t);
    const float* p = m_data->data() + m_offset + size_t(t) * m_stride +
                     (size_t(view) * size_t(m_info.nDirs()) + size_t(light)) * 3;
    return {p[0], p[1], p[2]};
  }
  std::string kind() const override { return m_kind; }

 private:
  void check(int64_t t) const {
    if (t < 0 || t >= m_info.texels())
      throw Error(
          format("texel %lld outside the level's %d×%d", (long long)t, m_info.nu, m_info.nv));
  }
  std::shared_ptr<const std::vector<float>> m_data;
  size_t m_offset, m_stride;
  std::string m_kind;
};

// Level k of a pyramid strip decoder.
class PyramidLevel final : public Decoder {
 public:
  PyramidLevel(std::shared_ptr<const Decoder> strip, BtfInfo info, int64_t first)
      : Decoder(std::move(info)), m_strip(std::move(strip)), m_first(first) {}
  void texel(int64_t t, float* out) const override {
    check(t);
    m_strip->texel(m_first + t, out);
  }
  std::array<float, 3> value(int64_t t, int view, int light) const override {
    check(t);
    return m_strip->value(m_first + t, view, light);
  }
  std::array<float, 3> evaluate(int64_t t, double thetaI, double phiI, double thetaO,
                                double phiO) const override {
    check(t);
    return m_strip->evaluate(m_first + t, thetaI, phiI, thetaO, phiO);
  }
  bool continuous() const override { return m_strip->continuous(); }
  std::string kind() const override { return m_strip->kind(); }

 private:
  void check(int64_t t) const {
    if (t < 0 || t >= m_info.texels())
      throw Error(
          format("texel %lld outside the level's %d×%d", (long long)t, m_info.nu, m_info.nv));
  }
  std::shared_ptr<const Decoder> m_strip;
  int64_t m_first;
};

void checkLevel(const std::string& what, int level, size_t count) {
  if (level < 0 || size_t(level) >= count)
    throw Error(format("%s: level %d does not exist (its levels are 0..%d)", what.c_str(), level,
                       int(count) - 1));
}

}  // namespace

void downsampleLevel(const std::function<const float*(int)>& fineRow, int nu, int nv, size_t stride,
                     int mu, int mv, float* out, const CancelToken* cancel) {
  const auto tx = boxTaps(nu, mu), ty = boxTaps(nv, mv);
  for (int j = 0; j < mv; ++j) {
    std::vector<const float*> rows;
    for (const BoxTap& b : ty[size_t(j)]) rows.push_back(fineRow(b.index));
    parallelForChunks(
        mu, 1,
        [&](int64_t i0, int64_t i1) {
          std::vector<double> acc(stride);
          for (int64_t i = i0; i < i1; ++i) {
            std::fill(acc.begin(), acc.end(), 0.0);
            for (size_t r = 0; r < rows.size(); ++r)
              for (const BoxTap& a : tx[size_t(i)]) {
                const double w = ty[size_t(j)][r].weight * a.weight;
                const float* src = rows[r] + size_t(a.index) * stride;
                for (size_t k = 0; k < stride; ++k) acc[k] += w * double(src[k]);
              }
            float* dst = out + (size_t(j) * size_t(mu) + size_t(i)) * stride;
            for (size_t k = 0; k < stride; ++k) dst[k] = float(acc[k]);
          }
        },
        cancel);
    throwIfCancelled(cancel, "texel levels");
  }
}

namespace {

// Levels 2..upTo from level 1 in `out` (already holding level 1 at its start).
void buildFromLevel1(std::vector<float>& out, const std::vector<MipLevel>& L, size_t stride,
                     int upTo, const CancelToken* cancel) {
  const int64_t base = L[1].first;
  for (int k = 2; k <= upTo; ++k) {
    const MipLevel &f = L[size_t(k - 1)], &c = L[size_t(k)];
    const float* fine = out.data() + size_t(f.first - base) * stride;
    downsampleLevel([&](int v) { return fine + size_t(v) * size_t(f.nu) * stride; }, f.nu, f.nv,
                    stride, c.nu, c.nv, out.data() + size_t(c.first - base) * stride, cancel);
  }
}

std::vector<float> allocateCoarse(const std::vector<MipLevel>& L, size_t stride, int upTo) {
  const int64_t n = L[size_t(upTo)].first + L[size_t(upTo)].texels() - L[1].first;
  return std::vector<float>(size_t(n) * stride);
}

}  // namespace

std::vector<float> buildCoarseLevels(const Decoder& base, int upTo, bool progress,
                                     const CancelToken* cancel) {
  const BtfInfo& I = base.info();
  const auto L = mipLevels(I.nu, I.nv);
  checkLevel("texel levels", upTo, L.size());
  if (upTo < 1) return {};
  const size_t stride = strideOf(I);
  std::vector<float> out = allocateCoarse(L, stride, upTo);
  // Level 1 from level 0's rows, read as the coarse rows ask for them (each at most once: the
  // boxes advance monotonically), the texels of a row in parallel.
  std::map<int, std::vector<float>> cache;
  ProgressReporter pr("texel levels", I.nv, progress);
  auto row = [&](int v) -> const float* {
    auto it = cache.find(v);
    if (it != cache.end()) return it->second.data();
    while (!cache.empty() && cache.begin()->first < v - 2) cache.erase(cache.begin());
    std::vector<float> r(size_t(I.nu) * stride);
    parallelForChunks(
        I.nu, 4,
        [&](int64_t u0, int64_t u1) {
          for (int64_t u = u0; u < u1; ++u)
            base.texel(u + int64_t(I.nu) * v, r.data() + size_t(u) * stride);
        },
        cancel);
    throwIfCancelled(cancel, "texel levels");
    pr.add(1);
    return cache.emplace(v, std::move(r)).first->second.data();
  };
  downsampleLevel(row, I.nu, I.nv, stride, L[1].nu, L[1].nv, out.data(), cancel);
  pr.finish();
  buildFromLevel1(out, L, stride, upTo, cancel);
  return out;
}

std::vector<float> buildCoarseLevels(const float* base, const BtfInfo& I, int upTo,
                                     const CancelToken* cancel) {
  const auto L = mipLevels(I.nu, I.nv);
  checkLevel("texel levels", upTo, L.size());
  if (upTo < 1) return {};
  const size_t stride = strideOf(I);
  std::vector<float> out = allocateCoarse(L, stride, upTo);
  downsampleLevel([&](int v) { return base + size_t(v) * size_t(I.nu) * stride; }, I.nu, I.nv,
                  stride, L[1].nu, L[1].nv, out.data(), cancel);
  buildFromLevel1(out, L, stride, upTo, cancel);
  return out;
}

std::vector<std::vector<float>> vmfLevels(const std::vector<float>& vmf, int nDirs, int nu, int nv,
                                          int upTo) {
  const auto L = mipLevels(nu, nv);
  checkLevel("visibility-map levels", upTo, L.size());
  if (vmf.size() != size_t(nDirs) * size_t(nu) * size_t(nv) * 2)
    throw Error("visibility-map levels: the map has the wrong size");
  std::vector<std::vector<float>> out;
  const std::vector<float>* fine = &vmf;
  for (int k = 1; k <= upTo; ++k) {
    const MipLevel &f = L[size_t(k - 1)], &c = L[size_t(k)];
    const auto tx = boxTaps(f.nu, c.nu), ty = boxTaps(f.nv, c.nv);
    std::vector<float> v(size_t(nDirs) * size_t(c.texels()) * 2, 0.f);
    for (int d = 0; d < nDirs; ++d)
      for (int j = 0; j < c.nv; ++j)
        for (int i = 0; i < c.nu; ++i) {
          float cov = 0, h = 0;
          bool any = false;
          for (const BoxTap& b : ty[size_t(j)])
            for (const BoxTap& a : tx[size_t(i)]) {
              const float* p = fine->data() + (size_t(d) * size_t(f.texels()) + size_t(a.index) +
                                               size_t(f.nu) * size_t(b.index)) *
                                                  2;
              if (!(p[0] > 0)) continue;
              cov = std::max(cov, std::min(p[0], 1.f));
              h = any ? std::max(h, p[1]) : p[1];
              any = true;
            }
          float* q =
              &v[(size_t(d) * size_t(c.texels()) + size_t(i) + size_t(c.nu) * size_t(j)) * 2];
          q[0] = cov, q[1] = h;
        }
    out.push_back(std::move(v));
    fine = &out.back();
  }
  return out;
}

BtfInfo pyramidInfo(const BtfInfo& base) {
  const int64_t n = pyramidTexels(mipLevels(base.nu, base.nv));
  if (n >= (int64_t(1) << 31))
    throw Error(format("a pyramid of %d×%d texels has too many texels (%lld)", base.nu, base.nv,
                       (long long)n));
  BtfInfo s = base;
  s.nu = int(n);
  s.nv = 1;
  return s;
}

BtfInfo levelInfo(const BtfInfo& base, const MipLevel& level) {
  BtfInfo s = base;
  s.nu = level.nu;
  s.nv = level.nv;
  s.chunkTexels = int(std::max<int64_t>(1, std::min<int64_t>(base.chunkTexels, level.texels())));
  return s;
}

std::unique_ptr<Decoder> pyramidLevel(std::shared_ptr<const Decoder> strip, const BtfInfo& base,
                                      int level) {
  const auto L = mipLevels(base.nu, base.nv);
  checkLevel("pyramid", level, L.size());
  if (strip->info().texels() != pyramidTexels(L))
    throw Error("pyramid: the decoder does not hold every level's texels");
  return std::make_unique<PyramidLevel>(std::move(strip), levelInfo(base, L[size_t(level)]),
                                        L[size_t(level)].first);
}

CompressedBtf asStrip(CompressedBtf c) {
  c.info = pyramidInfo(c.info);
  c.levels.clear();
  return c;
}

std::unique_ptr<Decoder> makePyramidDecoder(CompressedBtf c, int level) {
  const BtfInfo base = c.info;
  const std::string where = c.source.empty() ? std::string("compressed BTF") : c.source;
  checkLevel(where, level, c.levels.size());
  std::shared_ptr<const Decoder> strip = makeDecoder(asStrip(std::move(c)));
  return pyramidLevel(std::move(strip), base, level);
}

std::unique_ptr<Decoder> openBtfLevel(const std::string& path, int level, uint64_t memoryBudget,
                                      bool progress, const CancelToken* cancel) {
  std::unique_ptr<Decoder> base;
  if (isCompressedFile(path)) {
    CompressedBtf c = readCompressed(path);
    if (!c.levels.empty()) return makePyramidDecoder(std::move(c), level);
    base = makeDecoder(std::move(c));
  } else {
    base = openBtf(path);
  }
  const BtfInfo I = base->info();
  const auto L = mipLevels(I.nu, I.nv);
  checkLevel(path, level, L.size());
  if (level == 0) return base;
  const double bytes = double(L[size_t(level)].first + L[size_t(level)].texels() - L[1].first) *
                       double(I.texelBytes());
  if (memoryBudget > 0 && bytes > double(memoryBudget))
    throw Error(
        format("%s: building level %d by box filtering holds %s of texel levels, beyond "
               "the memory budget (%s)",
               path.c_str(), level, formatBytes(bytes).c_str(),
               formatBytes(double(memoryBudget)).c_str()));
  auto data =
      std::make_shared<const std::vector<float>>(buildCoarseLevels(*base, level, progress, cancel));
  const size_t offset = size_t(L[size_t(level)].first - L[1].first) * strideOf(I);
  return std::make_unique<MemoryLevel>(
      levelInfo(I, L[size_t(level)]), std::move(data), offset,
      base->kind() + " (box-filtered level " + std::to_string(level) + ")");
}

TexelFilter texelFilter(double la, double lb, int maxAniso, int levels) {
  TexelFilter f;
  if (!std::isfinite(la) || !std::isfinite(lb)) {
    f.lod = std::max(0, levels - 1);
    return f;
  }
  const bool aLong = la >= lb;
  const double major = aLong ? la : lb, minor = aLong ? lb : la;
  if (maxAniso == 0) {  // one tap, the long axis sets the level (isotropic trilinear)
    f.lod = std::clamp(std::log2(std::max(major, 1e-12)), 0.0, double(std::max(0, levels - 1)));
    return f;
  }
  const int nMinor = std::clamp(int(std::ceil(minor)), 1, 2);
  const double cell = std::max(minor / nMinor, 1e-12);
  const int nMajor =
      std::clamp(int(std::ceil(major / cell - 1e-6)), 1, std::max(1, maxAniso) * nMinor);
  const double width = std::max(major / nMajor, minor / nMinor);
  f.lod = std::clamp(std::log2(std::max(width, 1e-12)), 0.0, double(std::max(0, levels - 1)));
  if (major > 1) {
    f.na = aLong ? nMajor : nMinor;
    f.nb = aLong ? nMinor : nMajor;
  }
  return f;
}

std::array<float, 3> evaluateFiltered(const std::vector<const Decoder*>& levels, double x, double y,
                                      const double a[2], const double b[2], int maxAniso,
                                      double thetaI, double phiI, double thetaO, double phiO,
                                      double* lodOut) {
  if (levels.empty()) throw Error("evaluateFiltered: no levels");
  const TexelFilter f =
      texelFilter(std::hypot(a[0], a[1]), std::hypot(b[0], b[1]), maxAniso, int(levels.size()));
  if (lodOut) *lodOut = f.lod;
  const int top = int(levels.size()) - 1;
  const int l0 = std::min(int(f.lod), top), l1 = std::min(l0 + 1, top);
  const double fr = f.lod - l0, share = 1.0 / (double(f.na) * f.nb);
  const BtfInfo& base = levels[0]->info();
  std::array<double, 3> acc{0, 0, 0};
  auto add = [&](int k, double px, double py, double w) {
    const BtfInfo& I = levels[size_t(k)]->info();
    const auto v = levels[size_t(k)]->evaluateAt(px * I.nu / base.nu, py * I.nv / base.nv, thetaI,
                                                 phiI, thetaO, phiO);
    for (int c = 0; c < 3; ++c) acc[size_t(c)] += w * v[size_t(c)];
  };
  for (int j = 0; j < f.nb; ++j)
    for (int i = 0; i < f.na; ++i) {
      const double sa = (i + 0.5) / f.na - 0.5, sb = (j + 0.5) / f.nb - 0.5;
      const double px = x + sa * a[0] + sb * b[0], py = y + sa * a[1] + sb * b[1];
      if (fr < 1) add(l0, px, py, (1 - fr) * share);
      if (fr > 0 && l1 != l0) add(l1, px, py, fr * share);
    }
  return {float(acc[0]), float(acc[1]), float(acc[2])};
}

CompressedBtf compressPyramid(const std::string& inPath, const CodecSettings& s, bool progress,
                              const CancelToken* cancel, PyramidReport* report) {
  const auto start = Clock::now();
  if (isCompressedFile(inPath))
    throw Error(inPath + ": compress reads a raw BTF store (.btf), not a compressed file");
  PyramidReport r;
  const BtfReader reader(inPath);
  const std::unique_ptr<Decoder> base = openBtf(inPath);
  const BtfInfo& I = reader.info();
  const auto L = mipLevels(I.nu, I.nv);
  const int K = int(L.size()) - 1;
  const size_t stride = strideOf(I);
  const BtfInfo S = pyramidInfo(I);
  std::unique_ptr<Encoder> enc = makeEncoder(s, S, cancel);
  CompressedBtf vmfOnly;  // level 0's visibility map, coded; its bytes are not the codec's
  if (I.hasVmf) {
    vmfOnly.info = I;
    vmfOnly.setVmf(reader.readVmfAll());
    enc->reserveBytes(vmfOnly.vmfCoded.size());
  }
  const auto train = enc->trainingTexels();
  const double coarseBytes = double(S.texels() - I.texels()) * double(I.texelBytes());
  if (s.memoryBudget > 0) {
    const double encoder = double(enc->memoryBytes());
    const double training = double(train.size()) * double(I.texelBytes());
    const double chunk = double(I.chunkTexels) * double(I.texelBytes());
    if (coarseBytes + encoder + training + chunk > double(s.memoryBudget))
      throw Error("refusing to start: the pyramid of " + inPath + " needs about " +
                  formatBytes(coarseBytes + encoder + training + chunk) + " (levels 1.." +
                  std::to_string(K) + " " + formatBytes(coarseBytes) + ", encoder " +
                  formatBytes(encoder) + ", training texels " + formatBytes(training) +
                  ") but the memory budget is " + formatBytes(double(s.memoryBudget)) +
                  "; raise --memory-budget");
  }
  r.texels = S.texels();
  r.texelBytes = double(I.texelBytes());
  // Levels 1..K.
  auto t0 = Clock::now();
  auto coarse = std::make_shared<std::vector<float>>(
      K > 0 ? buildCoarseLevels(*base, K, progress, cancel) : std::vector<float>());
  r.levelSeconds = since(t0);
  auto pyramidTexel = [&](int64_t t, float* out) {
    if (t < I.texels())
      base->texel(t, out);
    else
      std::copy_n(coarse->data() + size_t(t - I.texels()) * stride, stride, out);
  };
  if (!train.empty()) {
    t0 = Clock::now();
    std::vector<float> values(train.size() * stride);
    for (size_t i = 0; i < train.size(); ++i) pyramidTexel(train[i], values.data() + i * stride);
    enc->train(values.data());
    r.trainSeconds = since(t0);
  }
  t0 = Clock::now();
  {
    ProgressReporter pr("encode " + s.codec + " pyramid", S.texels(), progress);
    for (int c = 0; c < I.chunks(); ++c) {
      throwIfCancelled(cancel, "compression");
      const std::vector<float> chunk = reader.readChunk(c);  // checksum verified
      enc->add(I.chunkBegin(c), I.chunkEnd(c), chunk.data());
      pr.add(I.chunkEnd(c) - I.chunkBegin(c));
    }
    const int64_t n = S.texels() - I.texels(), step = std::max(1, I.chunkTexels);
    for (int64_t a = 0; a < n; a += step) {
      throwIfCancelled(cancel, "compression");
      const int64_t b = std::min(n, a + step);
      enc->add(I.texels() + a, I.texels() + b, coarse->data() + size_t(a) * stride);
      pr.add(b - a);
    }
    pr.finish();
  }
  r.texelsEncoded = S.texels();
  r.encodeSeconds = since(t0);
  t0 = Clock::now();
  CompressedBtf out = enc->finish();
  r.finishSeconds = since(t0);
  out.info = I;
  out.levels = L;
  out.copyVmf(vmfOnly);  // level 0's; the coarser follow from it (vmfLevels)
  // Each level's error against the exact level (level 0 = the store itself).
  {
    std::shared_ptr<const Decoder> dec = makeDecoder(asStrip(out));
    nlohmann::ordered_json lv = nlohmann::ordered_json::array();
    for (int k = 0; k <= K; ++k) {
      const BtfInfo li = levelInfo(I, L[size_t(k)]);
      std::unique_ptr<Decoder> ref;
      if (k > 0)
        ref = std::make_unique<MemoryLevel>(
            li, coarse, size_t(L[size_t(k)].first - I.texels()) * stride, "raw level");
      const auto test = pyramidLevel(dec, I, k);
      const ErrorReport e = compareBtfs(k == 0 ? *base : *ref, *test, false, 0, cancel);
      r.levels.push_back({L[size_t(k)].nu, L[size_t(k)].nv, e.relRmse, e.rmse});
      lv.push_back({{"texels", {L[size_t(k)].nu, L[size_t(k)].nv}},
                    {"relative_rmse", e.relRmse},
                    {"rmse", e.rmse}});
    }
    nlohmann::ordered_json st = nlohmann::ordered_json::parse(out.statsJson);
    st["levels"] = lv;
    out.statsJson = st.dump();
  }
  finishReport(&r, out, since(start));
  if (report) *report = r;
  return out;
}

}  // namespace btf
