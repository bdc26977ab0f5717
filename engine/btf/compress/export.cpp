#include "export.h"

#include <btf/compress/compress.h>
#include <btf/core/error.h>
#include <btf/core/output_lock.h>
#include <btf/core/progress.h>
#include <btf/core/run_context.h>
#include <btf/directions/direction_set.h>
#include <btf/io/image_io.h>
#include <zip.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

namespace btf {
namespace {

int roundDeg(double d) {
  return int(std::lround(d));
}

std::string angleBlock(const char* t, const char* p, double thDeg, double phDeg) {
  char buf[32];
  int ph = roundDeg(phDeg) % 360;
  if (ph < 0) ph += 360;
  std::snprintf(buf, sizeof buf, "%s%03d_%s%03d", t, roundDeg(thDeg), p, ph);
  return buf;
}

template <class T>
void put(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}

}  // namespace

void writeFileAtomic(const std::string& path, const std::string& bytes) {
  const std::string partial = path + ".partial";
  {
    std::ofstream f(partial, std::ios::binary | std::ios::trunc);
    if (!f) throw Error(partial + ": cannot create");
    f.write(bytes.data(), std::streamsize(bytes.size()));
    f.flush();
    if (!f) throw Error(partial + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) throw Error(path + ": cannot rename into place (" + ec.message() + ")");
}

static std::string fmtDeg(double d) {
  char b[32];
  std::snprintf(b, sizeof b, "%.10g", d);
  return b;
}

namespace {

// Every file under `root` (relative names, '/'-separated, sorted) added to a new zip archive
// `zipPath`, stored (the images are compressed already; EXR half/float barely deflates).
void zipFolder(const std::string& root, const std::string& zipPath) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::recursive_directory_iterator(root))
    if (e.is_regular_file())
      names.push_back(std::filesystem::relative(e.path(), root).generic_string());
  std::sort(names.begin(), names.end());
  int err = 0;
  zip_t* z = zip_open(zipPath.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  if (!z) {
    zip_error_t ze;
    zip_error_init_with_code(&ze, err);
    const std::string why = zip_error_strerror(&ze);
    zip_error_fini(&ze);
    throw Error(zipPath + ": cannot create the zip archive (" + why + ")");
  }
  auto fail = [&](const std::string& what) {
    const std::string why = zip_strerror(z);
    zip_discard(z);
    throw Error(zipPath + ": " + what + " (" + why + ")");
  };
  for (const std::string& n : names) {
    zip_source_t* src = zip_source_file(z, (root + "/" + n).c_str(), 0, -1);
    if (!src) fail("cannot read " + n);
    const zip_int64_t idx = zip_file_add(z, n.c_str(), src, ZIP_FL_ENC_UTF_8);
    if (idx < 0) {
      zip_source_free(src);
      fail("cannot add " + n);
    }
    if (zip_set_file_compression(z, zip_uint64_t(idx), ZIP_CM_STORE, 0) != 0)
      fail("cannot store " + n);
  }
  if (zip_close(z) != 0) fail("cannot write the archive");
}

// Removes a folder when it goes out of scope (the staging folder of a zip export).
struct FolderGuard {
  std::string path;
  ~FolderGuard() {
    std::error_code ec;
    if (!path.empty()) std::filesystem::remove_all(path, ec);
  }
};

}  // namespace

Ubo2003Report exportUbo2003(const Decoder& d, const std::string& out, bool progress,
                            const CancelToken* cancel, const Ubo2003Options& o) {
  const BtfInfo& info = d.info();
  const int n = info.nDirs();
  if (o.imageFormat != "exr" && o.imageFormat != "png" && o.imageFormat != "jpg")
    throw Error("export ubo2003: unknown image format '" + o.imageFormat +
                "' (expected exr, png or jpg)");
  if (!(o.scale >= 0) || !std::isfinite(o.scale))
    throw Error("export ubo2003: --scale must be a finite number ≥ 0 (0 = 1 / peak)");
  const bool hdr = o.imageFormat == "exr";
  const std::string ext = "." + o.imageFormat;
  // Names must be unique after rounding to integer degrees.
  std::map<std::string, int> seen;
  std::vector<std::string> blocksL, blocksV;
  for (int i = 0; i < n; ++i) {
    const auto& a = info.dirsDeg[size_t(i)];
    const std::string b = angleBlock("tl", "pl", a[0], a[1]);
    if (seen.count(b))
      throw Error("export ubo2003: directions " + std::to_string(seen[b]) + " and " +
                  std::to_string(i) + " of set '" + info.directionSet +
                  "' round to the same integer-degree name " + b);
    seen[b] = i;
    blocksL.push_back(b);
    blocksV.push_back(angleBlock("tv", "pv", a[0], a[1]));
  }
  // A zip is staged in a folder beside it, then archived into OUT.partial and renamed.
  FolderGuard staging;
  std::string dir = out;
  if (o.zip) {
    dir = out + ".images.partial.d";
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
    staging.path = dir;
  }
  makeFolder(dir);
  const int64_t T = info.texels();
  const size_t lv = size_t(n) * n;
  std::vector<float> texel(lv * 3);
  Ubo2003Report rep;
  // 8-bit images: one scale for the whole set (peak → 1 unless given), stated in the sidecar.
  if (!hdr) {
    double peak = 0;
    if (o.scale <= 0) {
      for (int64_t t = 0; t < T; ++t) {
        d.texel(t, texel.data());
        for (float v : texel)
          if (std::isfinite(v)) peak = std::max(peak, double(v));
        throwIfCancelled(cancel, "export ubo2003");
      }
    }
    rep.scale = o.scale > 0 ? o.scale : peak > 0 ? 1.0 / peak : 1.0;
  }
  // Views in blocks so the decoded slab stays under ~512 MiB.
  const int64_t perView = T * n * 3 * 4;
  const int vb =
      int(std::clamp<int64_t>((int64_t(512) << 20) / std::max<int64_t>(1, perView), 1, n));
  std::vector<float> slab(size_t(T) * size_t(vb) * n * 3);
  ProgressReporter pr("export ubo2003", int64_t(n) * n, progress);
  uint64_t clipped = 0, values = 0;
  for (int v0 = 0; v0 < n; v0 += vb) {
    const int v1 = std::min(n, v0 + vb);
    for (int64_t t = 0; t < T; ++t) {
      d.texel(t, texel.data());
      for (int v = v0; v < v1; ++v)  // slab layout [view − v0][texel][light][rgb]
        std::memcpy(&slab[(size_t(v - v0) * size_t(T) + size_t(t)) * size_t(n) * 3],
                    &texel[size_t(v) * n * 3], size_t(n) * 3 * sizeof(float));
    }
    throwIfCancelled(cancel, "export ubo2003");
    for (int v = v0; v < v1; ++v) {
      throwIfCancelled(cancel, "export ubo2003");
      const std::string sub = dir + "/" + blocksV[size_t(v)];
      makeFolder(sub);
      for (int l = 0; l < n; ++l) {
        std::vector<float> img(size_t(T) * 3);
        for (int64_t t = 0; t < T; ++t)
          for (int c = 0; c < 3; ++c)
            img[size_t(t) * 3 + size_t(c)] =
                slab[((size_t(v - v0) * size_t(T) + size_t(t)) * size_t(n) + size_t(l)) * 3 +
                     size_t(c)];
        if (!hdr)
          for (float x : img) clipped += double(x) * rep.scale > 1.0, ++values;
        const std::string name = blocksL[size_t(l)] + "_" + blocksV[size_t(v)] + ext;
        const auto& dv = info.dirsDeg[size_t(v)];
        const auto& dl = info.dirsDeg[size_t(l)];
        writeRgbImage(sub + "/" + name, info.nu, info.nv, img, float(rep.scale), true,
                      {{"units", "aBRDF, 1/sr, linear RGB"},
                       {"view_theta_phi_deg", fmtDeg(dv[0]) + "," + fmtDeg(dv[1])},
                       {"light_theta_phi_deg", fmtDeg(dl[0]) + "," + fmtDeg(dl[1])},
                       {"scene", info.sceneName},
                       {"scene_hash", info.sceneHash}});
        ++rep.images;
        pr.add(1);
      }
    }
  }
  pr.finish();
  rep.clipped = values ? double(clipped) / double(values) : 0.0;
  nlohmann::ordered_json j;
  if (hdr) {
    j["format"] = "ubo2003-style image set (UTIA naming), one linear float EXR per (light, view)";
    j["values"] =
        "aBRDF in 1/sr (Lo / (E_perp cos theta_l)); NOT multiplied by cos theta_l; linear RGB";
  } else {
    j["format"] = "ubo2003-style image set (UTIA naming), one 8-bit sRGB " +
                  std::string(o.imageFormat == "png" ? "PNG" : "JPEG (quality 95)") +
                  " per (light, view)";
    j["values"] =
        "pixel/255 = srgb_encode(clamp(aBRDF * scale, 0, 1)); aBRDF in 1/sr, NOT multiplied by "
        "cos theta_l; linear aBRDF = srgb_decode(pixel/255) / scale";
    j["scale"] = rep.scale;
    j["clipped_fraction"] = rep.clipped;
  }
  j["names"] = "tvTTT_pvPPP/tlTTT_plPPP_tvTTT_pvPPP" + ext + ", integer degrees (rounded)";
  j["image_rows"] = "top row = texel row v = Nv-1 (y up); column = texel u";
  j["texels"] = {info.nu, info.nv};
  j["tile_size"] = {info.Lx, info.Ly};
  j["direction_set"] = info.directionSet;
  j["directions_theta_phi_deg"] = info.dirsDeg;
  j["scene"] = info.sceneName;
  j["source"] = d.kind();
  writeFileAtomic(dir + "/btf_export.json", j.dump(1) + "\n");
  if (o.zip) {
    throwIfCancelled(cancel, "export ubo2003");
    const std::string partial = out + ".partial";
    zipFolder(dir, partial);
    std::error_code ec;
    std::filesystem::rename(partial, out, ec);
    if (ec) throw Error(out + ": cannot rename into place (" + ec.message() + ")");
  }
  return rep;
}

Ubo2014Report exportUbo2014(const Decoder& d, const std::string& file, int components,
                            bool progress, const CancelToken* cancel, double targetRmse) {
  const BtfInfo& info = d.info();
  const int n = info.nDirs();
  const int64_t T = info.texels();
  const size_t stride = size_t(n) * n * 3;
  // Full-matrix SVD per RGB channel: the svd codec on the decoded texels, in f32.
  CodecSettings s;
  s.codec = "svd";
  s.colour = "rgb";
  s.half = false;
  s.components = std::max(0, components);
  s.targetRmse = components > 0 ? 0 : targetRmse;
  if (components <= 0 && !(targetRmse > 0 && targetRmse < 1))
    throw Error("export ubo2014: --target-rmse must be in (0, 1) when --components is 0");
  s.trainTexels = int(std::min<int64_t>(T, 1024));
  auto enc = makeEncoder(s, info, cancel);
  {
    // The basis comes from the training texels: decoding them and the SVD are most of the time
    // on small BTFs, so they have a bar of their own.
    const auto train = enc->trainingTexels();
    ProgressReporter pr("export ubo2014: training", int64_t(train.size()) + 1, progress);
    std::vector<float> tv(train.size() * stride);
    for (size_t i = 0; i < train.size(); ++i) {
      if (i % 64 == 0) throwIfCancelled(cancel, "export ubo2014");
      d.texel(train[i], tv.data() + i * stride);
      pr.add(1);
    }
    enc->train(tv.data());
    pr.add(1);
    pr.finish();
  }
  {
    ProgressReporter pr("export ubo2014", T, progress);
    std::vector<float> buf;
    const int64_t batch = 64;
    for (int64_t t0 = 0; t0 < T; t0 += batch) {
      throwIfCancelled(cancel, "export ubo2014");
      const int64_t t1 = std::min(T, t0 + batch);
      buf.resize(size_t(t1 - t0) * stride);
      for (int64_t t = t0; t < t1; ++t) d.texel(t, buf.data() + size_t(t - t0) * stride);
      enc->add(t0, t1, buf.data());
      pr.add(t1 - t0);
    }
    pr.finish();
  }
  CompressedBtf c = enc->finish();
  Ubo2014Report rep;
  rep.relRmse = nlohmann::json::parse(c.statsJson).value("training_relative_rmse", 0.0);
  {
    // What the file holds, measured on every texel through the svd decoder: the factors rounded
    // to fp16. The file stores U·b and K/b; their rounding differs from U's and K's only
    // within fp16's relative precision (2⁻¹¹), far below the error reported.
    CompressedBtf q = c;
    for (CArray& a : q.arrays) a.type = ArrayType::F16;
    q.quantize();
    const auto dec = makeDecoder(std::move(q));
    rep.measuredRmse = compareBtfs(d, *dec, progress, 0, cancel).relRmse;
  }

  std::string out;
  out.append("!DFMF08FCR", 10);
  // Meta block (version 4).
  const std::string xml;
  const char* names[3] = {"R", "G", "B"};
  const uint32_t size = 264 + 4 + (4 + uint32_t(xml.size())) + 4 + 3 * (4 + 1);
  put<uint32_t>(out, size);
  put<uint32_t>(out, 4);
  auto fixed = [&](const std::string& txt) {
    std::string f(80, '\0');
    std::memcpy(f.data(), txt.data(), std::min<size_t>(79, txt.size()));
    out += f;
  };
  fixed("BTF Studio simulation: " + info.sceneName);
  fixed("synthetic (aBRDF, 1/sr)");
  fixed("directional light");
  const float ppmm = float(info.nu / std::max(1e-9, info.Lx));
  put<float>(out, ppmm);
  for (int i = 0; i < 3; ++i) put<float>(out, 1.f);
  put<uint32_t>(out, 0);  // cosine_flag: values are aBRDF, cos θ_l not multiplied in
  put<uint32_t>(out, uint32_t(xml.size()));
  out += xml;
  put<uint32_t>(out, 3);
  for (const char* nm : names) {
    put<uint32_t>(out, 1);
    out += nm;
  }
  // Directions: nV views, each with the full light list.
  put<uint32_t>(out, uint32_t(n));
  for (int v = 0; v < n; ++v) {
    put<float>(out, float(info.dirsDeg[size_t(v)][0] * kPi / 180));
    put<float>(out, float(info.dirsDeg[size_t(v)][1] * kPi / 180));
    put<uint32_t>(out, uint32_t(n));
    for (int l = 0; l < n; ++l) {
      put<float>(out, float(info.dirsDeg[size_t(l)][0] * kPi / 180));
      put<float>(out, float(info.dirsDeg[size_t(l)][1] * kPi / 180));
    }
  }
  put<uint32_t>(out, uint32_t(info.nu));
  put<uint32_t>(out, uint32_t(info.nv));
  put<uint32_t>(out, 0);  // rotations
  int maxC = 0;
  for (int ch = 0; ch < 3; ++ch) {
    rep.components[ch] = int(c.array(channelArray(ch, "basis")).cols);
    maxC = std::max(maxC, rep.components[ch]);
  }
  put<uint32_t>(out, uint32_t(maxC));
  put<int32_t>(out, 0);  // colour model 0: RGB
  for (int i = 0; i < 3; ++i) put<float>(out, 0.f);
  for (int i = 0; i < 9; ++i) put<float>(out, i % 4 == 0 ? 1.f : 0.f);
  const int64_t rows = int64_t(n) * n;
  const double balance = std::sqrt(double(rows));  // U·√rows, SxV/√rows: both near data scale
  for (int ch = 0; ch < 3; ++ch) {
    const CArray& U = c.array(channelArray(ch, "basis"));  // rows v·nL + l = l + nL·v
    const CArray& K = c.array(channelArray(ch, "coef"));   // texel u + Nu·v
    const int C = int(U.cols);
    put<uint8_t>(out, 2);
    put<uint32_t>(out, uint32_t(C));
    put<uint32_t>(out, uint32_t(rows));
    put<uint32_t>(out, uint32_t(T));
    for (int k = 0; k < C; ++k) {
      double nrm = 0;
      for (int64_t t = 0; t < T; ++t) nrm += double(K.at(t, k)) * K.at(t, k);
      put<uint16_t>(out, la::floatToHalf(float(std::sqrt(nrm))));
    }
    for (int64_t r = 0; r < rows; ++r)
      for (int k = 0; k < C; ++k) put<uint16_t>(out, la::floatToHalf(float(U.at(r, k) * balance)));
    for (int64_t t = 0; t < T; ++t)
      for (int k = 0; k < C; ++k) put<uint16_t>(out, la::floatToHalf(float(K.at(t, k) / balance)));
  }
  writeFileAtomic(file, out);
  rep.bytes = out.size();
  return rep;
}

void merlBinCentre(int ih, int id, int ip, double* th, double* td, double* pd) {
  const double x = (ih + 0.5) / 90.0;
  *th = x * x * (kPi / 2);  // inverse of θh_i = ⌊90·√(θh / (π/2))⌋
  *td = (id + 0.5) / 90.0 * (kPi / 2);
  *pd = (ip + 0.5) / 180.0 * kPi;
}

void halfDiffToDirections(double th, double ph, double td, double pd, double wi[3], double wo[3]) {
  // In the half-vector frame: ω_i = (sinθd cosφd, sinθd sinφd, cosθd), ω_o its mirror about h.
  const double d[2][3] = {
      {std::sin(td) * std::cos(pd), std::sin(td) * std::sin(pd), std::cos(td)},
      {-std::sin(td) * std::cos(pd), -std::sin(td) * std::sin(pd), std::cos(td)}};
  for (int k = 0; k < 2; ++k) {
    // Rotate by θh about y, then by φh about z.
    const double x = d[k][0] * std::cos(th) + d[k][2] * std::sin(th);
    const double y = d[k][1];
    const double z = -d[k][0] * std::sin(th) + d[k][2] * std::cos(th);
    double* w = k == 0 ? wi : wo;
    w[0] = x * std::cos(ph) - y * std::sin(ph);
    w[1] = x * std::sin(ph) + y * std::cos(ph);
    w[2] = z;
  }
}

MerlReport exportMerl(const Decoder& d, const std::string& file, int phiSamples, bool progress,
                      const CancelToken* cancel) {
  if (phiSamples < 1) throw Error("export merl: --phi-samples must be ≥ 1");
  const BtfInfo& info = d.info();
  const int n = info.nDirs();
  const int64_t T = info.texels();
  // Texel average.
  std::vector<double> avg(size_t(n) * n * 3, 0.0);
  {
    std::vector<float> buf(avg.size());
    ProgressReporter pr("texel average", T, progress);
    for (int64_t t = 0; t < T; ++t) {
      if (t % 64 == 0) throwIfCancelled(cancel, "export merl");
      d.texel(t, buf.data());
      for (size_t i = 0; i < buf.size(); ++i) avg[i] += buf[i];
      pr.add(1);
    }
    pr.finish();
    for (double& x : avg) x /= double(T);
  }
  const DirectionSet ds = DirectionSet::fromName(info.directionSet);
  auto eval = [&](const double wi[3], const double wo[3], double rgb[3]) {
    const double ti = std::acos(std::clamp(wi[2], -1.0, 1.0)), pi = std::atan2(wi[1], wi[0]);
    const double to = std::acos(std::clamp(wo[2], -1.0, 1.0)), po = std::atan2(wo[1], wo[0]);
    const auto li = ds.interpolate(ti, pi < 0 ? pi + 2 * kPi : pi);
    const auto vo = ds.interpolate(to, po < 0 ? po + 2 * kPi : po);
    rgb[0] = rgb[1] = rgb[2] = 0;
    for (const auto& a : vo)
      for (const auto& b : li)
        for (int c = 0; c < 3; ++c)
          rgb[c] +=
              a.weight * b.weight * avg[(size_t(a.index) * n + size_t(b.index)) * 3 + size_t(c)];
  };
  const int64_t N = 90 * 90 * 180;
  std::vector<double> vals(size_t(N) * 3, -1.0);
  const double scale[3] = {1.0 / 1500, 1.15 / 1500, 1.66 / 1500};
  MerlReport rep;
  rep.bins = N;
  double spreadSum = 0;
  int64_t spreadCount = 0;
  ProgressReporter pr("export merl", 90, progress);
  std::vector<int64_t> missing(90, 0);
  std::vector<double> spreadS(90, 0.0);
  std::vector<int64_t> spreadN(90, 0);
  std::vector<double> asymDiff(90, 0.0), asymSum(90, 0.0), asymMax(90, 0.0);
  parallelForChunks(
      90, 1,
      [&](int64_t h0, int64_t h1) {
        for (int64_t ih = h0; ih < h1; ++ih) {
          for (int id = 0; id < 90; ++id)
            for (int ip = 0; ip < 180; ++ip) {
              double th, td, pd;
              merlBinCentre(int(ih), id, ip, &th, &td, &pd);
              double sum[3] = {0, 0, 0}, sumL = 0, sumL2 = 0, asymD = 0, asymS = 0;
              int valid = 0;
              for (int k = 0; k < phiSamples; ++k) {
                const double ph = (k + 0.5) * 2 * kPi / phiSamples;
                double wi[3], wo[3], rgb[3], back[3];
                halfDiffToDirections(th, ph, td, pd, wi, wo);
                if (wi[2] <= 0 || wo[2] <= 0) continue;
                eval(wi, wo, rgb);
                eval(wo, wi, back);
                asymD += std::abs((rgb[0] + rgb[1] + rgb[2]) - (back[0] + back[1] + back[2]));
                asymS += 0.5 * (rgb[0] + rgb[1] + rgb[2] + back[0] + back[1] + back[2]);
                for (int c = 0; c < 3; ++c) rgb[c] = 0.5 * (rgb[c] + back[c]);
                for (int c = 0; c < 3; ++c) sum[c] += rgb[c];
                const double lum = (rgb[0] + rgb[1] + rgb[2]) / 3;
                sumL += lum;
                sumL2 += lum * lum;
                ++valid;
              }
              const int64_t idx = ip + 180 * (id + 90 * ih);
              if (valid == 0) {
                missing[size_t(ih)]++;
                continue;
              }
              for (int c = 0; c < 3; ++c)
                vals[size_t(c) * N + size_t(idx)] = sum[c] / valid / scale[c];
              asymDiff[size_t(ih)] += asymD;
              asymSum[size_t(ih)] += asymS;
              if (asymS > 1e-12) asymMax[size_t(ih)] = std::max(asymMax[size_t(ih)], asymD / asymS);
              if (valid > 1 && sumL > 0) {
                const double mean = sumL / valid;
                const double var = std::max(0.0, sumL2 / valid - mean * mean);
                spreadS[size_t(ih)] += std::sqrt(var) / mean;
                spreadN[size_t(ih)]++;
              }
            }
          pr.add(1);
        }
      },
      cancel);
  throwIfCancelled(cancel, "export merl");
  pr.finish();
  for (int i = 0; i < 90; ++i) {
    rep.missingBins += missing[size_t(i)];
    spreadSum += spreadS[size_t(i)];
    spreadCount += spreadN[size_t(i)];
  }
  rep.anisotropy = spreadCount ? spreadSum / double(spreadCount) : 0;
  double aD = 0, aS = 0;
  for (int i = 0; i < 90; ++i) {
    aD += asymDiff[size_t(i)];
    aS += asymSum[size_t(i)];
    rep.asymmetryMax = std::max(rep.asymmetryMax, asymMax[size_t(i)]);
  }
  rep.asymmetry = aS > 0 ? aD / aS : 0;
  std::string out;
  put<int32_t>(out, 90);
  put<int32_t>(out, 90);
  put<int32_t>(out, 180);
  out.append(reinterpret_cast<const char*>(vals.data()), vals.size() * sizeof(double));
  writeFileAtomic(file, out);
  return rep;
}

}  // namespace btf
