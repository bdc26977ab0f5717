// The common codec interface (docs/compression.md). Every codec — the thesis's per-texel
// NMF + PCA and the baselines (global SVD, per-view PCA, clustered local PCA) — encodes from a
// stream of texels (any chunking, so the simulator can feed it directly) after an optional
// training pass on a fixed, stratified subset of texels, and decodes through one Decoder API.
// Texel values are [view][light][rgb] float aBRDF, as in the raw store.
#pragma once
#include <btf/compress/cbtf.h>
#include <btf/compress/linalg.h>
#include <btf/core/comm.h>
#include <btf/core/error.h>
#include <btf/core/parallel.h>
#include <btf/store/btf_store.h>

#include <array>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace btf {

class ProgressReporter;

struct CodecSettings {
  std::string codec = "nmf";   // nmf | svd | perview | lpca | tensor | neural
  std::string colour = "ycc";  // rgb | ycc (Y = mean of RGB, U = R − Y, V = B − Y)
  // Components: explicit (> 0) or from a target (relative RMSE or ratio); else the default
  // target below.
  int components = 0;
  double targetRmse = 0;   // relative RMSE (RMSE / RMS of the data)
  double targetRatio = 0;  // raw float RGB bytes / compressed bytes
  // Per-texel NMF (§3.4).
  double beta = 0.995;
  la::BetaMode betaMode = la::BetaMode::Energy;
  la::NmfSolver solver = la::NmfSolver::Hals;
  int maxRank = 8;
  int nmfIterations = 60;
  double nmfTolerance = 1e-4;
  // Baselines.
  int trainTexels = 256;      // stratified training subset (per-view, global SVD, clustered PCA)
  int clusters = 0;           // lpca, tensor (0 = the codec's default: 8; √(texels / 2))
  bool halfway = false;       // tensor: factorise each view's slice in half-vector coordinates
  // Neural (codec_neural.cpp): latent size = components (0: from the target), the decoder's
  // hidden layers and width, Adam steps and learning rate, the direction encoding.
  int neuralHidden = 32;
  int neuralLayers = 2;
  int neuralSteps = 4000;
  double neuralRate = 2e-2;
  std::string neuralEncoding = "fourier";  // fourier | halfdiff | raw
  bool half = true;           // f16 arrays (else f32)
  uint64_t memoryBudget = 0;  // > 0: compressStore refuses to start beyond it
  uint64_t seed = 1;
};

/// The codec names, in the order reports list them.
const std::vector<std::string>& codecNames();
/// Checks names and ranges; btf::Error names the option.
void validate(const CodecSettings& s);
std::string settingsJson(const CodecSettings& s);

/// "c{channel}.{what}": the name of a channel's array in the file.
std::string channelArray(int channel, const char* what);

/// Colour decorrelation shared by all codecs.
int colourChannels(const std::string& colour);  // 3 for both models (ycc keeps 3 channels)
bool channelNonNegative(const std::string& colour, int c);
void toColour(const std::string& colour, const float rgb[3], float out[3]);
void fromColour(const std::string& colour, const float in[3], float rgb[3]);

class Encoder {
 public:
  virtual ~Encoder() = default;
  /// Texels the codec needs before the stream (sorted; empty for per-texel codecs).
  virtual std::vector<int64_t> trainingTexels() const { return {}; }
  /// Their values, in trainingTexels() order, texel-major.
  virtual void train(const float* /*values*/) {}
  /// Texels [t0, t1), texel-major. Called in any order, one call at a time.
  virtual void add(int64_t t0, int64_t t1, const float* values) = 0;
  /// Prints the codec's own long stages (training) on stderr.
  virtual void setProgress(bool /*on*/) {}
  /// Builds the arrays (quantized as they will be stored).
  virtual CompressedBtf finish() = 0;
  /// Memory the encoder holds (for the budget check and the estimate).
  virtual uint64_t memoryBytes() const = 0;
  /// A cluster job (docs/cluster.md): what add() computed for every texel this encoder was
  /// given, as bytes that an encoder of the same settings and training merges (mergeAdded)
  /// before its finish(). The merged encoder writes the bytes one encoder fed every texel writes.
  virtual std::string addedState() const = 0;
  virtual void mergeAdded(const std::string& bytes) = 0;
  /// finish() over the ranks of a job, each having added its share of the texels: by default
  /// rank 0 merges every rank's state (addedState) in rank order and finishes; a codec may
  /// instead reduce its statistics and gather only its output (nmf). Every rank calls it; rank 0
  /// gets the file, the others an empty CompressedBtf. On one process, finish().
  virtual CompressedBtf finishOn(Comm& comm);
  /// Bytes the file holds beside the codec's arrays (its visibility map): a --target-ratio
  /// budget leaves them out, so that the whole file lands at the ratio asked. Before train().
  void reserveBytes(uint64_t n) { m_reservedBytes = n; }

 protected:
  uint64_t m_reservedBytes = 0;
};

/// Appends and reads back the plain values of encoder states (addedState / mergeAdded).
class StateWriter {
 public:
  template <class T>
  void put(const T& v) {
    m_s.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T>
  void putVector(const std::vector<T>& v) {
    put<uint64_t>(v.size());
    m_s.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string take() { return std::move(m_s); }

 private:
  std::string m_s;
};
class StateReader {
 public:
  explicit StateReader(const std::string& s) : m_s(s) {}
  template <class T>
  T get() {
    T v;
    need(sizeof v);
    std::memcpy(&v, m_s.data() + m_o, sizeof v);
    m_o += sizeof v;
    return v;
  }
  template <class T>
  std::vector<T> getVector(uint64_t maxCount) {
    const uint64_t n = get<uint64_t>();
    if (n > maxCount) throw Error("encoder state: a record holds more values than it can");
    need(n * sizeof(T));
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), m_s.data() + m_o, n * sizeof(T));
    m_o += n * sizeof(T);
    return v;
  }
  bool done() const { return m_o == m_s.size(); }

 private:
  void need(uint64_t n) const {
    if (n > m_s.size() - m_o) throw Error("encoder state: truncated");
  }
  const std::string& m_s;
  size_t m_o = 0;
};

/// Stratified subset of n texels over the Nu × Nv grid (one per cell of a near-square grid of
/// cells, jittered by a hash of seed): fixed for a given (Nu, Nv, n, seed).
std::vector<int64_t> stratifiedTexels(int nu, int nv, int n, uint64_t seed);

std::unique_ptr<Encoder> makeEncoder(const CodecSettings& s, const BtfInfo& info,
                                     const CancelToken* cancel = nullptr);

class Decoder {
 public:
  virtual ~Decoder() = default;
  const BtfInfo& info() const { return m_info; }
  /// Every value of a texel: out[(view · nL + light) · 3 + c], RGB, ≥ 0 and finite.
  virtual void texel(int64_t t, float* out) const = 0;
  /// One value (what a shader does).
  virtual std::array<float, 3> value(int64_t t, int view, int light) const = 0;
  /// aBRDF at a texel for any directions (radians): interpolated between the set's directions
  /// (bilinear on θ × φ grids, ring-linear on the Bonn sets; DirectionSet::interpolate), or the
  /// codec's own continuous decode (neural).
  virtual std::array<float, 3> evaluate(int64_t t, double thetaI, double phiI, double thetaO,
                                        double phiO) const;
  /// True when evaluate() is the codec's own function of direction (not interpolation).
  virtual bool continuous() const { return false; }
  /// Same at a tile position (x, y) in texel units, bilinear between the four nearest texels
  /// (periodic).
  std::array<float, 3> evaluateAt(double x, double y, double thetaI, double phiI, double thetaO,
                                  double phiO) const;
  virtual std::string kind() const = 0;

 protected:
  explicit Decoder(BtfInfo info);
  BtfInfo m_info;
  std::shared_ptr<const class DirectionSet> m_dirs;
};

std::unique_ptr<Decoder> makeDecoder(CompressedBtf c);

/// `d` presented at another direction set (`target`'s, same texels): every value is
/// d.evaluate() at the target's pair — the codec's own continuous decode (neural), else
/// interpolation between d's set directions. What `compare` uses to measure a file between its
/// set directions against a simulation at other directions.
std::unique_ptr<Decoder> atDirections(std::shared_ptr<const Decoder> d, const BtfInfo& target);

/// What a GLSL tensor decoder needs beside the file's arrays (shaders/btf_decode.glsl), derived
/// from them as the CPU decoder does: per texel (cluster, offset of its coefficients, offset of
/// its Rv × Rl matrices in `matrices` or −1), per channel and cluster 7 floats (Rv, Rl, Rt, offsets
/// of the cluster's view, light and core blocks, offset of its G block in `matrices` or −1).
/// `matrices` holds, when they fit in maxMatrixFloats (and 2^24, the floats' exact integers),
/// either the per-(cluster, view, light) projected cores G[(v·n + l)·Rt + j] = x_vᵀ core_j y_l
/// (preferred: a value is Rt products) or else the per-texel matrices M; or nothing.
struct TensorGpuTables {
  std::vector<float> texels;
  std::vector<float> clusters[3];
  std::vector<float> matrices;
  bool projected = false;  // `matrices` holds the G blocks (else M per texel, or nothing)
};
TensorGpuTables tensorGpuTables(const CompressedBtf& c, uint64_t maxMatrixFloats);
/// Opens a raw store or a compressed file (by magic bytes) behind the Decoder API.
std::unique_ptr<Decoder> openBtf(const std::string& path);

// Codec factories (codec_*.cpp).
std::unique_ptr<Encoder> makeNmfEncoder(const CodecSettings&, const BtfInfo&, const CancelToken*);
std::unique_ptr<Encoder> makeSvdEncoder(const CodecSettings&, const BtfInfo&, const CancelToken*);
std::unique_ptr<Encoder> makePerViewEncoder(const CodecSettings&, const BtfInfo&,
                                            const CancelToken*);
std::unique_ptr<Encoder> makeLpcaEncoder(const CodecSettings&, const BtfInfo&, const CancelToken*);
std::unique_ptr<Encoder> makeTensorEncoder(const CodecSettings&, const BtfInfo&,
                                           const CancelToken*);
std::unique_ptr<Encoder> makeNeuralEncoder(const CodecSettings&, const BtfInfo&,
                                           const CancelToken*);
std::unique_ptr<Decoder> makeNeuralDecoder(CompressedBtf c);
std::unique_ptr<Decoder> makeNmfDecoder(CompressedBtf c);
std::unique_ptr<Decoder> makeTensorDecoder(CompressedBtf c);
std::unique_ptr<Decoder> makeSvdDecoder(CompressedBtf c);
std::unique_ptr<Decoder> makePerViewDecoder(CompressedBtf c);
std::unique_ptr<Decoder> makeLpcaDecoder(CompressedBtf c);

}  // namespace btf
