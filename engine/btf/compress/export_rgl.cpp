// The RGL measured-BSDF export (export.h, docs/exports.md): the tile-averaged aBRDF as a
// "tensor_file" of named fields, the layout Mitsuba 3's and pbrt-v4's `measured` BSDFs read.
#include <btf/compress/export.h>
#include <btf/compress/lookup.h>
#include <btf/core/error.h>
#include <btf/core/run_context.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace btf {

namespace {

constexpr double kPiD = 3.14159265358979323846;

// Dupuy & Jakob's unit square: u ↦ θ = u²·π/2, v ↦ φ = (2v − 1)·π.
double u2theta(double u) {
  return u * u * kPiD / 2;
}
double u2phi(double v) {
  return (2 * v - 1) * kPiD;
}
double theta2u(double t) {
  return std::sqrt(std::max(0.0, t) * 2 / kPiD);
}
double phi2u(double p) {
  return (p + kPiD) / (2 * kPiD);
}

// One named field of a tensor file.
struct Field {
  std::string name;
  uint8_t dtype = 10;  // Struct::Type: 1 = UInt8, 10 = Float32
  std::vector<uint64_t> shape;
  std::string bytes;
};

Field floats(const std::string& name, std::vector<uint64_t> shape, const std::vector<float>& v) {
  uint64_t n = 1;
  for (uint64_t s : shape) n *= s;
  BTF_CHECK(n == v.size());
  Field f{name, 10, std::move(shape), std::string(v.size() * sizeof(float), '\0')};
  std::memcpy(f.bytes.data(), v.data(), f.bytes.size());
  return f;
}

// "tensor_file\0", version 1.0, the field count, each field's name, rank, type, data offset and
// shape (little-endian), then the data, each field 8-byte aligned.
std::string tensorFile(const std::vector<Field>& fields) {
  std::string head("tensor_file\0", 12);
  head.push_back(1);
  head.push_back(0);
  auto put = [](std::string& s, auto v) { s.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(head, uint32_t(fields.size()));
  size_t headerBytes = head.size();
  for (const Field& f : fields) headerBytes += 2 + f.name.size() + 2 + 1 + 8 + 8 * f.shape.size();
  uint64_t offset = (headerBytes + 7) / 8 * 8;
  std::string data;
  for (const Field& f : fields) {
    put(head, uint16_t(f.name.size()));
    head += f.name;
    put(head, uint16_t(f.shape.size()));
    put(head, f.dtype);
    put(head, offset + data.size());
    for (uint64_t s : f.shape) put(head, s);
    data += f.bytes;
    data.resize((data.size() + 7) / 8 * 8, '\0');
  }
  head.resize(offset, '\0');
  return head + data;
}

double luminance(const float* rgb) {
  return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

}  // namespace

RglReport exportRglBsdf(const Decoder& d, const std::vector<std::array<double, 3>>& areaNormals,
                        double tileArea, const std::string& file, const std::string& description,
                        const CancelToken* cancel, const RglOptions& o) {
  if (o.thetaI < 2 || o.phiI < 3 || o.resolution < 2 || o.ndfResolution < 2 ||
      o.sigmaResolution < 2)
    throw Error("export rgl-bsdf: grid resolutions must be at least 2 (3 azimuths)");
  if (!(tileArea > 0)) throw Error("export rgl-bsdf: the tile has no area");
  // The tile average as a one-texel BTF: lookups at any pair of directions, interpolated between
  // the set's directions as every other reader does.
  BtfInfo one = d.info();
  one.nu = one.nv = 1;
  const std::vector<float> avg = tileAverage(d, cancel);

  const int nt = o.thetaI, np = o.phiI, N = o.resolution;
  std::vector<float> thetaI(static_cast<size_t>(nt)), phiI(static_cast<size_t>(np));
  const double maxTheta = 89.0 * kPiD / 180;
  for (int t = 0; t < nt; ++t) thetaI[size_t(t)] = float(maxTheta * t / (nt - 1));
  for (int p = 0; p < np; ++p) phiI[size_t(p)] = float(-kPiD + 2 * kPiD * p / (np - 1));

  // Every (view, half vector) node: the light is the view mirrored about m.
  const size_t nodes = size_t(np) * size_t(nt) * size_t(N) * size_t(N);
  std::vector<double> uv(nodes * 2, 0.5), wi(nodes * 3), wo(nodes * 3);
  std::vector<double> cosLight(nodes);
  size_t k = 0;
  for (int p = 0; p < np; ++p)
    for (int t = 0; t < nt; ++t) {
      const double st = std::sin(thetaI[size_t(t)]), ct = std::cos(thetaI[size_t(t)]);
      const double v[3] = {st * std::cos(phiI[size_t(p)]), st * std::sin(phiI[size_t(p)]), ct};
      for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x, ++k) {
          const double tm = u2theta(double(x) / (N - 1)), pm = u2phi(double(y) / (N - 1));
          const double m[3] = {std::sin(tm) * std::cos(pm), std::sin(tm) * std::sin(pm),
                               std::cos(tm)};
          const double dm = v[0] * m[0] + v[1] * m[1] + v[2] * m[2];
          for (int c = 0; c < 3; ++c) {
            wi[k * 3 + size_t(c)] = 2 * dm * m[c] - v[c];  // the light
            wo[k * 3 + size_t(c)] = v[c];                  // the view
          }
          cosLight[k] = wi[k * 3 + 2];
        }
    }
  throwIfCancelled(cancel, "export rgl-bsdf");
  std::vector<float> f(nodes * 3);
  evaluateBatch(one, avg.data(), nodes, uv.data(), wi.data(), wo.data(), f.data(), cancel);
  std::vector<float> rgb(nodes * 3), lum(nodes);
  double peak = 0;
  for (size_t n = 0; n < nodes; ++n) {
    const double c = std::max(0.0, cosLight[n]);
    for (int ch = 0; ch < 3; ++ch) f[n * 3 + size_t(ch)] = float(f[n * 3 + size_t(ch)] * c);
    peak = std::max(peak, luminance(&f[n * 3]));
  }
  // rgb: [φ_i, θ_i, channel, y, x]; luminance [φ_i, θ_i, y, x], floored a little above zero
  // where the light is above the horizon so that importance sampling reaches every lit value.
  const size_t NN = size_t(N) * size_t(N);
  for (size_t s = 0; s < size_t(np) * size_t(nt); ++s)
    for (size_t q = 0; q < NN; ++q) {
      const size_t n = s * NN + q;
      for (int ch = 0; ch < 3; ++ch) rgb[(s * 3 + size_t(ch)) * NN + q] = f[n * 3 + size_t(ch)];
      lum[n] = float(std::max(luminance(&f[n * 3]), cosLight[n] > 0 ? 1e-4 * peak + 1e-12 : 0.0));
    }
  std::vector<float> vndf(nodes, 1.0f);

  // The micro-geometry's NDF on the unit square: each upward facet's area spread bilinearly over
  // the four nodes around its normal, divided by the node's solid angle; D is per steradian of
  // m with ∫ D cos θ_m dω = Σ A_f cos θ_f / A_tile.
  const int M = o.ndfResolution;
  std::vector<double> mass(size_t(M) * size_t(M), 0.0);
  double projected = 0, up = 0;
  for (const auto& an : areaNormals) {
    const double a = std::sqrt(an[0] * an[0] + an[1] * an[1] + an[2] * an[2]);
    if (!(a > 0) || !std::isfinite(a) || an[2] <= 0) continue;
    const double nz = std::min(1.0, an[2] / a);
    const double fx = theta2u(std::acos(nz)) * (M - 1),
                 fy = phi2u(std::atan2(an[1], an[0])) * (M - 1);
    const int x0 = std::min(M - 2, int(fx)), y0 = std::min(M - 2, int(fy));
    const double ax = fx - x0, ay = fy - y0;
    const double w = a / tileArea;
    mass[size_t(y0) * M + size_t(x0)] += w * (1 - ax) * (1 - ay);
    mass[size_t(y0) * M + size_t(x0 + 1)] += w * ax * (1 - ay);
    mass[size_t(y0 + 1) * M + size_t(x0)] += w * (1 - ax) * ay;
    mass[size_t(y0 + 1) * M + size_t(x0 + 1)] += w * ax * ay;
    projected += w * nz;
    up += 1;
  }
  // At θ_m = 0 every φ is the same normal: the column's mass spread evenly over its rows.
  {
    double col = 0;
    for (int y = 0; y < M; ++y) col += mass[size_t(y) * M];
    for (int y = 0; y < M; ++y)
      mass[size_t(y) * M] = col / (M - 1) * (y == 0 || y == M - 1 ? 0.5 : 1.0);
  }
  // A node's cell: half a step either side in u and v (the edges' half cells); φ wraps, so the
  // first and last rows (φ = ±π) share their mass.
  std::vector<float> ndf(size_t(M) * size_t(M));
  const double h = 1.0 / (M - 1);
  for (int x = 0; x < M; ++x) {
    const double u0 = std::max(0.0, (x - 0.5) * h), u1 = std::min(1.0, (x + 0.5) * h);
    // Solid angle of the cell per unit v: ∫ sin θ dθ over [θ(u0), θ(u1)] times 2π per unit v.
    const double band = std::cos(u2theta(u0)) - std::cos(u2theta(u1));
    for (int y = 0; y < M; ++y) {
      const double v0 = std::max(0.0, (y - 0.5) * h), v1 = std::min(1.0, (y + 0.5) * h);
      double m = mass[size_t(y) * M + size_t(x)];
      double dv = v1 - v0;
      if (y == 0 || y == M - 1) {
        m = mass[size_t(x)] + mass[size_t(M - 1) * M + size_t(x)];
        dv = h;  // both half rows together
      }
      const double omega = band * 2 * kPiD * dv;
      // D · cos θ_m integrates the mass: D = mass / (Ω · cos θ_m) at the cell.
      const double cm = std::cos(u2theta(0.5 * (u0 + u1)));
      ndf[size_t(y) * M + size_t(x)] = omega > 0 ? float(m / (omega * std::max(cm, 1e-6))) : 0.f;
    }
  }
  // σ(ω) = Σ A_f max(0, n_f · ω) / A_tile on the unit square of ω.
  const int S = o.sigmaResolution;
  std::vector<float> sigma(size_t(S) * size_t(S));
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      const double t = u2theta(double(x) / (S - 1)), p = u2phi(double(y) / (S - 1));
      const double w[3] = {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
      double s = 0;
      for (const auto& an : areaNormals) {
        if (!(an[2] > 0)) continue;
        s += std::max(0.0, an[0] * w[0] + an[1] * w[1] + an[2] * w[2]);
      }
      sigma[size_t(y) * S + size_t(x)] = float(s / tileArea);
    }
  throwIfCancelled(cancel, "export rgl-bsdf");
  for (float v : rgb)
    if (!std::isfinite(v)) throw Error("export rgl-bsdf: a non-finite value in the source");

  std::vector<Field> fields;
  Field desc{"description", 1, {description.size()}, description};
  fields.push_back(desc);
  fields.push_back(floats("theta_i", {uint64_t(nt)}, thetaI));
  fields.push_back(floats("phi_i", {uint64_t(np)}, phiI));
  fields.push_back(floats("ndf", {uint64_t(M), uint64_t(M)}, ndf));
  fields.push_back(floats("sigma", {uint64_t(S), uint64_t(S)}, sigma));
  fields.push_back(floats("vndf", {uint64_t(np), uint64_t(nt), uint64_t(N), uint64_t(N)}, vndf));
  fields.push_back(
      floats("luminance", {uint64_t(np), uint64_t(nt), uint64_t(N), uint64_t(N)}, lum));
  fields.push_back(floats("rgb", {uint64_t(np), uint64_t(nt), 3, uint64_t(N), uint64_t(N)}, rgb));
  fields.push_back(Field{"jacobian", 1, {1}, std::string(1, '\0')});
  const std::string bytes = tensorFile(fields);
  writeFileAtomic(file, bytes);
  RglReport r;
  r.bytes = bytes.size();
  r.thetaI = nt, r.phiI = np, r.resolution = N;
  r.ndfProjectedArea = projected;
  r.facets = up;
  return r;
}

}  // namespace btf
