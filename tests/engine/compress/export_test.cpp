// Exports read back by independent readers written here from ../shared/FORMATS.md (file names,
// byte layouts and index formulas re-derived in the test, not taken from our exporter).
#include <btf/compress/compress.h>
#include <btf/compress/export.h>
#include <btf/core/error.h>
#include <btf/io/image_io.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>

#include "engine/compress/synthetic.h"
#include "test_util.h"

using namespace btf;
using namespace btf::test;

namespace {

struct Bytes {
  std::string s;
  size_t pos = 0;
  template <class T>
  T get() {
    T v;
    EXPECT_LE(pos + sizeof(T), s.size());
    std::memcpy(&v, s.data() + pos, sizeof(T));
    pos += sizeof(T);
    return v;
  }
  std::string str(size_t n) {
    std::string r = s.substr(pos, n);
    pos += n;
    return r;
  }
};

// IEEE half → float, written independently of the engine's converter.
float fromHalf(uint16_t h) {
  const int e = (h >> 10) & 31, m = h & 1023;
  const float sign = (h & 0x8000) ? -1.f : 1.f;
  if (e == 0) return sign * std::ldexp(float(m), -24);
  if (e == 31) return sign * INFINITY;
  return sign * std::ldexp(float(m + 1024), e - 25);
}

// The entries of a zip archive whose members are stored (method 0), read from the central
// directory as APPNOTE.TXT lays it out: name → bytes. Fails on anything else (deflate, ZIP64).
std::map<std::string, std::string> readStoredZip(const std::string& path) {
  std::map<std::string, std::string> out;
  Bytes z{readFile(path)};
  size_t eocd = std::string::npos;
  for (size_t k = z.s.size() >= 22 ? z.s.size() - 22 : 0;; --k) {
    if (std::memcmp(z.s.data() + k, "PK\x05\x06", 4) == 0) {
      eocd = k;
      break;
    }
    if (k == 0) break;
  }
  EXPECT_NE(eocd, std::string::npos) << path << ": no end of central directory";
  if (eocd == std::string::npos) return out;
  z.pos = eocd + 10;
  const uint16_t entries = z.get<uint16_t>();
  z.get<uint32_t>();  // central directory size
  z.pos = z.get<uint32_t>();
  for (int e = 0; e < entries; ++e) {
    EXPECT_EQ(z.get<uint32_t>(), 0x02014b50u);
    z.pos += 6;
    const uint16_t method = z.get<uint16_t>();
    z.pos += 8;
    const uint32_t csize = z.get<uint32_t>(), usize = z.get<uint32_t>();
    const uint16_t nlen = z.get<uint16_t>(), xlen = z.get<uint16_t>(), clen = z.get<uint16_t>();
    z.pos += 8;
    const uint32_t local = z.get<uint32_t>();
    const std::string name = z.str(nlen);
    z.pos += size_t(xlen) + clen;
    EXPECT_EQ(method, 0) << name;
    EXPECT_EQ(csize, usize) << name;
    Bytes l{z.s, local};
    EXPECT_EQ(l.get<uint32_t>(), 0x04034b50u) << name;
    l.pos = local + 26;
    const uint16_t ln = l.get<uint16_t>(), lx = l.get<uint16_t>();
    out[name] = z.s.substr(local + 30 + ln + lx, csize);
  }
  return out;
}

// The direction of `info` whose rounded (θ, φ mod 360) in degrees is (th, ph), or −1.
int directionNamed(const BtfInfo& info, int th, int ph) {
  for (int i = 0; i < info.nDirs(); ++i)
    if (std::lround(info.dirsDeg[size_t(i)][0]) == th &&
        std::lround(info.dirsDeg[size_t(i)][1]) % 360 == ph)
      return i;
  return -1;
}

float srgbDecode(float p) {
  return p <= 0.04045f ? p / 12.92f : std::pow((p + 0.055f) / 1.055f, 2.4f);
}

}  // namespace

TEST(Export, Ubo2003ImageSetReadBackByNames) {
  const auto dir = tempDir("export_ubo2003");
  const BtfInfo info = syntheticInfo(3, 2, "bonn81");
  const auto raw = openBtf(writeRaw((dir / "a.btf").string(), info, syntheticValues(info, {4})));
  const std::string out = (dir / "set").string();
  EXPECT_EQ(exportUbo2003(*raw, out, false).images, 81 * 81);
  // Reader: every .exr under the folder; the angle block ends the name.
  const std::regex re("tl(\\d{3})[ _]pl(\\d{3})[ _]tv(\\d{3})[ _]pv(\\d{3})\\.exr$");
  auto indexOf = [&](int th, int ph) { return directionNamed(info, th, ph); };
  int files = 0, checked = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(out)) {
    if (e.path().extension() != ".exr") continue;
    ++files;
    std::smatch m;
    const std::string name = e.path().filename().string();
    ASSERT_TRUE(std::regex_search(name, m, re)) << name;
    const int l = indexOf(std::stoi(m[1]), std::stoi(m[2])),
              v = indexOf(std::stoi(m[3]), std::stoi(m[4]));
    ASSERT_GE(l, 0) << name;
    ASSERT_GE(v, 0) << name;
    if ((l * 7 + v) % 97 != 0) continue;  // check a spread subset of the pixels
    int w = 0, h = 0;
    const auto img = readRgbImage(e.path().string(), &w, &h);
    ASSERT_EQ(w, info.nu);
    ASSERT_EQ(h, info.nv);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int texel = x + info.nu * (info.nv - 1 - y);  // top row = v = Nv − 1
        const auto val = raw->value(texel, v, l);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(img[(size_t(y) * w + x) * 3 + c], val[size_t(c)],
                      1e-6 * (1 + val[size_t(c)]));
      }
    ++checked;
  }
  EXPECT_EQ(files, 81 * 81);
  EXPECT_GT(checked, 50);
  const std::string side = readFile(out + "/btf_export.json");
  EXPECT_NE(side.find("aBRDF in 1/sr"), std::string::npos);
  EXPECT_NE(side.find("NOT multiplied by cos"), std::string::npos);
  // Directions that round to the same integer-degree name are refused before writing.
  const BtfInfo dense = syntheticInfo(1, 1, "128x4");
  const auto d2 =
      openBtf(writeRaw((dir / "dense.btf").string(), dense, syntheticValues(dense, {})));
  try {
    exportUbo2003(*d2, (dir / "dense").string(), false);
    FAIL() << "colliding names accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("same integer-degree name"), std::string::npos)
        << e.what();
  }
}

TEST(Export, Ubo2014ContainerReadBackByAnIndependentParser) {
  const auto dir = tempDir("export_ubo2014");
  const BtfInfo info = syntheticInfo(4, 3, "4x8");
  const auto raw = openBtf(writeRaw((dir / "a.btf").string(), info, syntheticValues(info, {5})));
  const std::string file = (dir / "a_dfmf.btf").string();
  const Ubo2014Report rep = exportUbo2014(*raw, file, 4, false);
  Bytes b{readFile(file)};
  EXPECT_EQ(b.str(10), "!DFMF08FCR");
  const size_t sizeAt = b.pos;
  const uint32_t size = b.get<uint32_t>();
  EXPECT_EQ(b.get<uint32_t>(), 4u);  // version
  b.str(240);                        // three 80-byte strings
  b.get<float>();                    // ppmm
  for (int i = 0; i < 3; ++i) b.get<float>();
  EXPECT_EQ(b.get<uint32_t>(), 0u);  // cosine flag: aBRDF, cos not multiplied in
  const uint32_t xml = b.get<uint32_t>();
  b.str(xml);
  const uint32_t nch = b.get<uint32_t>();
  ASSERT_EQ(nch, 3u);
  uint32_t names = 0;
  for (uint32_t c = 0; c < nch; ++c) {
    const uint32_t len = b.get<uint32_t>();
    names += 4 + len;
    b.str(len);
  }
  EXPECT_EQ(size, 264u + 4 + (4 + xml) + 4 + names);
  EXPECT_EQ(b.pos - sizeAt, size);  // Size counts from the Size field itself
  const uint32_t nV = b.get<uint32_t>();
  ASSERT_EQ(int(nV), info.nDirs());
  std::vector<std::array<float, 2>> lights;
  for (uint32_t v = 0; v < nV; ++v) {
    const float tv = b.get<float>(), pv = b.get<float>();
    EXPECT_NEAR(tv, info.dirsDeg[v][0] * M_PI / 180, 1e-6);
    EXPECT_NEAR(pv, info.dirsDeg[v][1] * M_PI / 180, 1e-6);
    const uint32_t nL = b.get<uint32_t>();
    ASSERT_EQ(nL, nV);  // known readers need nV = nL
    for (uint32_t l = 0; l < nL; ++l) {
      const float tl = b.get<float>(), pl = b.get<float>();
      if (v == 0)
        lights.push_back({tl, pl});
      else
        EXPECT_TRUE(lights[l][0] == tl && lights[l][1] == pl);  // identical for every view
    }
  }
  const uint32_t W = b.get<uint32_t>(), H = b.get<uint32_t>();
  EXPECT_EQ(int(W), info.nu);
  EXPECT_EQ(int(H), info.nv);
  EXPECT_EQ(b.get<uint32_t>(), 0u);  // rotations
  const uint32_t maxC = b.get<uint32_t>();
  EXPECT_EQ(b.get<int32_t>(), 0);  // colour model RGB
  for (int i = 0; i < 3; ++i) EXPECT_EQ(b.get<float>(), 0.f);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(b.get<float>(), i % 4 == 0 ? 1.f : 0.f);
  std::vector<std::vector<float>> U(3), SxV(3);
  std::vector<uint32_t> C(3);
  const uint32_t nL = nV;
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(b.get<uint8_t>(), 2);  // fp16
    C[size_t(c)] = b.get<uint32_t>();
    EXPECT_LE(C[size_t(c)], maxC);
    EXPECT_EQ(b.get<uint32_t>(), nL * nV);
    EXPECT_EQ(b.get<uint32_t>(), W * H);
    for (uint32_t k = 0; k < C[size_t(c)]; ++k) b.get<uint16_t>();  // S
    for (uint32_t i = 0; i < nL * nV * C[size_t(c)]; ++i)
      U[size_t(c)].push_back(fromHalf(b.get<uint16_t>()));
    for (uint32_t i = 0; i < W * H * C[size_t(c)]; ++i)
      SxV[size_t(c)].push_back(fromHalf(b.get<uint16_t>()));
  }
  EXPECT_EQ(b.pos, b.s.size());  // no trailing bytes
  EXPECT_EQ(rep.bytes, b.s.size());
  // Reconstruction: value_c(l, v, x, y) = Σ_k U[l + nL·v, k] · SxV[x + W·y, k].
  double worst = 0, peak = 0;
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x)
      for (uint32_t v = 0; v < nV; ++v)
        for (uint32_t l = 0; l < nL; ++l) {
          const auto ref = raw->value(int64_t(x + W * y), int(v), int(l));
          for (int c = 0; c < 3; ++c) {
            double s = 0;
            for (uint32_t k = 0; k < C[size_t(c)]; ++k)
              s += double(U[size_t(c)][(l + nL * v) * C[size_t(c)] + k]) *
                   SxV[size_t(c)][(x + W * y) * C[size_t(c)] + k];
            worst = std::max(worst, std::abs(s - ref[size_t(c)]));
            peak = std::max(peak, double(ref[size_t(c)]));
          }
        }
  EXPECT_LT(worst, 3e-3 * peak);  // fp16 factors of a rank-2 BTF
}

namespace {
// Rusinkiewicz half/difference angles, derived here: h = (ωi + ωo)/|…|; the difference vector is
// ωi rotated by −φh about z then −θh about y.
void halfDiff(const double wi[3], const double wo[3], double* th, double* td, double* pd) {
  double h[3] = {wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]};
  const double n = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
  for (double& x : h) x /= n;
  *th = std::acos(std::min(1.0, h[2]));
  const double ph = std::atan2(h[1], h[0]);
  const double a[3] = {wi[0] * std::cos(-ph) - wi[1] * std::sin(-ph),
                       wi[0] * std::sin(-ph) + wi[1] * std::cos(-ph), wi[2]};
  const double d[3] = {a[0] * std::cos(-*th) + a[2] * std::sin(-*th), a[1],
                       -a[0] * std::sin(-*th) + a[2] * std::cos(-*th)};
  *td = std::acos(std::min(1.0, d[2]));
  *pd = std::atan2(d[1], d[0]);
}
int merlIndex(double th, double td, double pd) {
  if (pd < 0) pd += M_PI;
  const int ih = std::clamp(int(std::floor(90 * std::sqrt(th / (M_PI / 2)))), 0, 89);
  const int id = std::clamp(int(std::floor(td / (M_PI / 2) * 90)), 0, 89);
  const int ip = std::clamp(int(std::floor(pd / M_PI * 180)), 0, 179);
  return ip + 180 * (id + 90 * ih);
}
std::array<double, 3> dirOf(double thDeg, double phDeg) {
  const double t = thDeg * M_PI / 180, p = phDeg * M_PI / 180;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}
}  // namespace

TEST(Export, MerlBinaryReadBackWithTheIndexFormula) {
  const auto dir = tempDir("export_merl");
  // Spatially uniform, isotropic aBRDF: a(θh) = 0.1 + cos⁸θh per channel weight, on a fine grid.
  BtfInfo info = syntheticInfo(2, 2, "24x48");
  const DirectionSet ds = DirectionSet::fromName(info.directionSet);
  const int n = info.nDirs();
  const double col[3] = {0.9, 0.6, 0.3};
  auto f = [&](const double wi[3], const double wo[3], int c) {
    double th, td, pd;
    halfDiff(wi, wo, &th, &td, &pd);
    return col[c] * (0.1 + std::pow(std::cos(th), 8));
  };
  std::vector<float> values(size_t(info.texels()) * n * n * 3);
  for (int64_t t = 0; t < info.texels(); ++t)
    for (int v = 0; v < n; ++v)
      for (int l = 0; l < n; ++l) {
        const double wi[3] = {ds[l].w.x, ds[l].w.y, ds[l].w.z},
                     wo[3] = {ds[v].w.x, ds[v].w.y, ds[v].w.z};
        for (int c = 0; c < 3; ++c)
          values[((size_t(t) * n + v) * n + l) * 3 + c] = float(f(wi, wo, c));
      }
  const auto raw = openBtf(writeRaw((dir / "a.btf").string(), info, values));
  const std::string file = (dir / "a.binary").string();
  const MerlReport rep = exportMerl(*raw, file, 16, false);
  EXPECT_LT(rep.anisotropy, 0.05);  // isotropic data
  Bytes b{readFile(file)};
  ASSERT_EQ(b.s.size(), 34992012u);
  EXPECT_EQ(b.get<int32_t>(), 90);
  EXPECT_EQ(b.get<int32_t>(), 90);
  EXPECT_EQ(b.get<int32_t>(), 180);
  const int N = 90 * 90 * 180;
  std::vector<double> data(size_t(3) * N);
  std::memcpy(data.data(), b.s.data() + 12, data.size() * 8);
  const double scale[3] = {1.0 / 1500, 1.15 / 1500, 1.66 / 1500};
  // Direction pairs, both orders of the reciprocal pair, read through the index formula.
  int checked = 0;
  for (double ti : {0.0, 20.0, 45.0, 60.0})
    for (double to : {10.0, 35.0, 55.0})
      for (double dphi : {0.0, 60.0, 135.0, 180.0}) {
        const auto wi = dirOf(ti, 30), wo = dirOf(to, 30 + dphi);
        double th, td, pd;
        halfDiff(wi.data(), wo.data(), &th, &td, &pd);
        const int idx = merlIndex(th, td, pd);
        for (int c = 0; c < 3; ++c) {
          const double v = data[size_t(c) * N + size_t(idx)] * scale[c];
          ASSERT_GE(v, 0) << "bin missing for θi " << ti << " θo " << to;
          // The bin's value is the BRDF near the bin centre; a(θh) varies inside a bin, so the
          // tolerance covers half a bin of θh plus the direction interpolation.
          const double exact = f(wi.data(), wo.data(), c);
          EXPECT_NEAR(v, exact, 0.06 * exact + 0.01) << ti << " " << to << " " << dphi << " c" << c;
        }
        ++checked;
      }
  EXPECT_EQ(checked, 48);
  // Bins whose every φh sample is below the horizon are missing (negative).
  EXPECT_LT(data[size_t(merlIndex(80 * M_PI / 180 * 80 / 90, 89.5 * M_PI / 180, 0.0))], 0);
  EXPECT_GT(rep.missingBins, 0);
}

TEST(Export, Ubo2014ChoosesItsComponentsFromTheErrorItMayAdd) {
  const auto dir = tempDir("export_ubo2014_target");
  // Rank 2 per texel with 20 texels of different mixtures: one component is far off, two exact.
  const BtfInfo info = syntheticInfo(5, 4, "4x8");
  const auto raw = openBtf(writeRaw((dir / "a.btf").string(), info, syntheticValues(info, {})));
  const Ubo2014Report one = exportUbo2014(*raw, (dir / "one.btf").string(), 1, false);
  EXPECT_GT(one.measuredRmse, 0.02);
  const Ubo2014Report rep = exportUbo2014(*raw, (dir / "t.btf").string(), 0, false, nullptr, 0.01);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(rep.components[c], 2) << "channel " << c;
  EXPECT_LT(rep.measuredRmse, 0.01);  // fp16 rounding only
  EXPECT_THROW(exportUbo2014(*raw, (dir / "x.btf").string(), 0, false, nullptr, 0.0), Error);
}

TEST(Export, MerlSymmetrisesANonReciprocalSourceAndMeasuresIt) {
  const auto dir = tempDir("export_merl_recip");
  // Isotropic, spatially uniform, NOT reciprocal: f = 0.2 + 0.5·cos θi·(1 − cos θo).
  const BtfInfo info = syntheticInfo(2, 2, "12x24");
  const DirectionSet ds = DirectionSet::fromName(info.directionSet);
  const int n = info.nDirs();
  std::vector<float> values(size_t(info.texels()) * n * n * 3);
  for (int64_t t = 0; t < info.texels(); ++t)
    for (int v = 0; v < n; ++v)
      for (int l = 0; l < n; ++l)
        for (int c = 0; c < 3; ++c)
          values[((size_t(t) * n + v) * n + l) * 3 + size_t(c)] =
              float(0.2 + 0.5 * ds[l].w.z * (1 - ds[v].w.z));
  const auto raw = openBtf(writeRaw((dir / "a.btf").string(), info, values));
  const std::string file = (dir / "a.binary").string();
  const MerlReport rep = exportMerl(*raw, file, 16, false);
  EXPECT_GT(rep.asymmetry, 0.05);  // measured and reported
  EXPECT_GT(rep.asymmetryMax, rep.asymmetry);
  // Swapping ωi and ωo maps φd to φd + π; with the mirror symmetry of this source the bins
  // φd and π − φd then hold the same value once f(ωi, ωo) and f(ωo, ωi) are averaged.
  Bytes b{readFile(file)};
  const int N = 90 * 90 * 180;
  std::vector<double> data(size_t(3) * N);
  std::memcpy(data.data(), b.s.data() + 12, data.size() * 8);
  double worst = 0, peak = 0;
  for (int ih = 0; ih < 90; ih += 7)
    for (int id = 0; id < 90; id += 5)
      for (int ip = 0; ip < 90; ip += 3) {
        const double a = data[size_t(ip + 180 * (id + 90 * ih))];
        const double c = data[size_t(179 - ip + 180 * (id + 90 * ih))];
        if (a < 0 || c < 0) continue;  // below the horizon
        worst = std::max(worst, std::abs(a - c));
        peak = std::max(peak, a);
      }
  EXPECT_GT(peak, 0);
  EXPECT_LT(worst, 1e-9 * peak);
  // A reciprocal source reports no asymmetry.
  for (int64_t t = 0; t < info.texels(); ++t)
    for (int v = 0; v < n; ++v)
      for (int l = 0; l < n; ++l)
        for (int c = 0; c < 3; ++c)
          values[((size_t(t) * n + v) * n + l) * 3 + size_t(c)] =
              float(0.2 + 0.5 * ds[l].w.z * ds[v].w.z);
  const auto sym = openBtf(writeRaw((dir / "s.btf").string(), info, values));
  EXPECT_LT(exportMerl(*sym, (dir / "s.binary").string(), 16, false).asymmetry, 1e-6);
}

TEST(Export, Ubo2003JpegZipAndPngAsThePyPIReadersTakeThem) {
  // btf-extractor's Ubo2003 reads a zip of JPEGs and takes the angles from the last 27
  // characters of each entry's name: "tlTTT?plPPP?tvTTT?pvPPP.jpg", at fixed positions.
  const auto dir = tempDir("export_ubo2003_zip");
  const BtfInfo info = syntheticInfo(4, 3, "bonn81");
  const auto raw = openBtf(writeRaw((dir / "a.btf").string(), info, syntheticValues(info, {4})));
  float peak = 0;
  {
    std::vector<float> t(size_t(info.nDirs()) * info.nDirs() * 3);
    for (int64_t k = 0; k < info.texels(); ++k) {
      raw->texel(k, t.data());
      for (float v : t) peak = std::max(peak, v);
    }
  }
  ASSERT_GT(peak, 0);
  auto indexOf = [&](int th, int ph) { return directionNamed(info, th, ph); };
  for (const char* fmt : {"jpg", "png"}) {
    SCOPED_TRACE(fmt);
    Ubo2003Options o;
    o.imageFormat = fmt;
    o.zip = true;
    const std::string zipPath = (dir / (std::string(fmt) + ".zip")).string();
    const Ubo2003Report rep = exportUbo2003(*raw, zipPath, false, nullptr, o);
    EXPECT_EQ(rep.images, 81 * 81);
    EXPECT_NEAR(rep.scale, 1.0 / peak, 1e-6 / peak);
    EXPECT_EQ(rep.clipped, 0.0);
    EXPECT_FALSE(std::filesystem::exists(zipPath + ".partial"));
    EXPECT_FALSE(std::filesystem::exists(zipPath + ".images.partial.d"));
    const auto entries = readStoredZip(zipPath);
    ASSERT_EQ(entries.size(), size_t(81 * 81 + 1));
    ASSERT_TRUE(entries.count("btf_export.json"));
    const std::string side = entries.at("btf_export.json");
    EXPECT_NE(side.find("srgb_decode(pixel/255) / scale"), std::string::npos);
    EXPECT_NE(side.find("\"scale\""), std::string::npos);
    const std::string ext = std::string(".") + fmt;
    int images = 0, checked = 0;
    double worst = 0, sum2 = 0;
    int64_t count = 0;
    for (const auto& [name, bytes] : entries) {
      if (name.size() < 27 || name.substr(name.size() - 4) != ext) continue;
      ++images;
      const std::string b = name.substr(name.size() - 27);
      ASSERT_EQ(b.substr(0, 2), "tl") << name;
      ASSERT_EQ(b.substr(6, 2), "pl") << name;
      ASSERT_EQ(b.substr(12, 2), "tv") << name;
      ASSERT_EQ(b.substr(18, 2), "pv") << name;
      const int l = indexOf(std::stoi(b.substr(2, 3)), std::stoi(b.substr(8, 3)));
      const int v = indexOf(std::stoi(b.substr(14, 3)), std::stoi(b.substr(20, 3)));
      ASSERT_GE(l, 0) << name;
      ASSERT_GE(v, 0) << name;
      if ((l * 7 + v) % 61 != 0) continue;
      const std::string tmp = (dir / ("one" + ext)).string();
      {
        std::ofstream f(tmp, std::ios::binary);
        f.write(bytes.data(), std::streamsize(bytes.size()));
      }
      int w = 0, h = 0;
      const auto img = readRgbImage(tmp, &w, &h);
      ASSERT_EQ(w, info.nu);
      ASSERT_EQ(h, info.nv);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const auto val = raw->value(x + info.nu * (info.nv - 1 - y), v, l);  // top row = Nv − 1
          for (int c = 0; c < 3; ++c) {
            const float lin =
                srgbDecode(img[(size_t(y) * w + x) * 3 + size_t(c)]) / float(rep.scale);
            const double e = double(std::abs(lin - val[size_t(c)])) / peak;
            worst = std::max(worst, e);
            sum2 += e * e, ++count;
          }
        }
      ++checked;
    }
    EXPECT_EQ(images, 81 * 81);
    EXPECT_GT(checked, 80);
    // 8 bits of sRGB: ≤ 1/255 of the peak at worst near black (PNG). JPEG (quality 95, 4:4:4)
    // adds its loss — largest on these noise-like 4×3 images, whose every texel differs.
    const double rms = std::sqrt(sum2 / double(std::max<int64_t>(1, count)));
    std::printf("  %s in a zip: |value − read back| / peak: worst %.4f, RMS %.4f\n", fmt, worst,
                rms);
    if (std::string(fmt) == "png") {
      EXPECT_LT(worst, 0.004);
    } else {
      EXPECT_LT(worst, 0.1);
      EXPECT_LT(rms, 0.02);
    }
  }
  // Bad options are clear errors, and nothing is left behind.
  Ubo2003Options bad;
  bad.imageFormat = "tiff";
  try {
    exportUbo2003(*raw, (dir / "bad.zip").string(), false, nullptr, bad);
    FAIL() << "tiff accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown image format 'tiff'"), std::string::npos);
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.zip"));
}
