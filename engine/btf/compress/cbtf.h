// The compressed BTF container (`.cbtf`, docs/compressed-format.md): a checksummed JSON header
// naming the codec, its settings and the BTF's geometry, then named 2-D arrays (rows × cols,
// row-major, f16 or f32), each 64-byte aligned and checksummed, laid out so a GLSL shader can
// bind each array as a texture buffer and decode with the codec's formula.
#pragma once
#include <btf/store/btf_store.h>
#include <btf/store/levels.h>

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace btf {

enum class ArrayType { F16, F32 };

struct CArray {
  std::string name;
  ArrayType type = ArrayType::F16;
  int64_t rows = 0, cols = 0;
  std::vector<float> data;  // in memory always float; F16 arrays hold values exactly representable
  float at(int64_t r, int64_t c) const { return data[size_t(r * cols + c)]; }
  float* row(int64_t r) { return data.data() + r * cols; }
  const float* row(int64_t r) const { return data.data() + r * cols; }
  /// Callers bound rows × cols first (the reader checks it against the file size).
  uint64_t storedBytes() const {
    return uint64_t(rows) * uint64_t(cols) * (type == ArrayType::F16 ? 2u : 4u);
  }
};

struct CompressedBtf {
  BtfInfo info;        // geometry, directions, provenance of the source (chunking unused)
  std::string source;  // the file it was read from ("" when built in memory): errors name it
  std::string codec;   // "nmf", "svd", "perview", "lpca"
  std::string colour;  // "rgb" or "ycc"
  std::string paramsJson = "{}";  // codec settings and chosen ranks (JSON object text)
  std::string statsJson = "{}";   // encode time, peak memory, training error (JSON object text)
  std::deque<CArray> arrays;      // deque: references from add() stay valid
  /// A pyramid (`compress --mip`, docs/mip.md): mipLevels(info.nu, info.nv), whose texels the
  /// arrays code one after the other; empty for a single-level file.
  std::vector<MipLevel> levels;
  /// The visibility map of level 0 (the raw store's: per direction, per texel u + nu·v,
  /// coverage and mean depth), coded (docs/compression.md, "The visibility map"): coverage and
  /// depth quantised to 8 bits (depth over [vmfDepth[0], vmfDepth[1]]), as two planes, deflated.
  /// Empty when the source had none (a flat tile).
  std::vector<uint8_t> vmfCoded;
  float vmfDepth[2] = {0, 0};

  /// Codes `vmf` (nDirs × texels × 2 floats, of info's level 0) into vmfCoded.
  void setVmf(const std::vector<float>& vmf);
  /// The coded map of `other` (the same level 0), as setVmf left it there.
  void copyVmf(const CompressedBtf& other) {
    vmfCoded = other.vmfCoded;
    vmfDepth[0] = other.vmfDepth[0], vmfDepth[1] = other.vmfDepth[1];
  }
  bool hasVmf() const { return !vmfCoded.empty(); }
  /// The decoded map (nDirs × texels × 2 floats); btf::Error when the coded bytes are damaged.
  std::vector<float> vmf() const;

  const CArray& array(const std::string& name) const;
  bool hasArray(const std::string& name) const;
  CArray& add(std::string name, ArrayType type, int64_t rows, int64_t cols);
  /// Rounds every F16 array through half precision (what the file will hold) and replaces
  /// non-finite values by 0.
  void quantize();
  uint64_t payloadBytes() const;  // Σ stored array bytes
  uint64_t fileBytes() const;     // header + alignment + arrays + the visibility map
  double ratio() const;           // raw float RGB bytes (of level 0) / file bytes
};

/// Writes `path` atomically (PATH.partial, fsync, rename).
void writeCompressed(const std::string& path, const CompressedBtf& c);
/// Reads and verifies (header and every array checksum, exact file size); btf::Error names the
/// file and what is wrong.
CompressedBtf readCompressed(const std::string& path);
/// True when the file starts with the compressed magic bytes.
bool isCompressedFile(const std::string& path);

}  // namespace btf
