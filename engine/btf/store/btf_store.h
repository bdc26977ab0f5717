// The raw BTF container (docs/store-format.md): a JSON header with every setting, a table of
// per-chunk checksums, the visibility map, then aBRDF data chunked by texel ranges, texel-major
// ([texel][view][light][rgb] float32). Written to OUT.partial and renamed when complete, so a
// killed run never leaves a corrupt OUT; the .partial resumes chunk by chunk.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace btf {

struct BtfInfo {
  // Geometry of the data.
  int nu = 0, nv = 0;
  double Lx = 1, Ly = 1;
  std::string directionSet;                    // name accepted by DirectionSet::fromName
  std::vector<std::array<double, 2>> dirsDeg;  // (θ, φ) in degrees, shared by view and light
  int chunkTexels = 1;
  // Settings and provenance.
  int spp = 1;
  std::string shadows = "map";
  double shadowBias = 1.0;
  uint64_t seed = 1;
  std::string sceneName;
  std::string sceneHash;  // hex checksum of the canonical scene and its geometry
  std::string sceneJson;  // canonical scene (every parameter)
  std::string plan;       // JSON of the effect plan / extra settings, free-form
  bool hasVmf = true;     // false when the plan dropped the visibility map (flat tile)

  int nDirs() const { return int(dirsDeg.size()); }
  int64_t texels() const { return int64_t(nu) * nv; }
  uint64_t texelBytes() const { return uint64_t(nDirs()) * nDirs() * 3 * sizeof(float); }
  int chunks() const { return int((texels() + chunkTexels - 1) / chunkTexels); }
  int64_t chunkBegin(int c) const { return int64_t(c) * chunkTexels; }
  int64_t chunkEnd(int c) const { return std::min<int64_t>(texels(), chunkBegin(c) + chunkTexels); }
};

std::string infoToJson(const BtfInfo& info);
BtfInfo infoFromJson(const std::string& json, const std::string& file);

/// Byte layout of a store with this header (offsets shared by writer and reader).
struct BtfLayout {
  uint64_t headerBytes = 0, tableOffset = 0, vmfOffset = 0, vmfBytes = 0, dataOffset = 0,
           totalBytes = 0;
  static BtfLayout of(const BtfInfo& info, uint64_t headerJsonBytes);
  uint64_t chunkOffset(const BtfInfo& info, int c) const {
    return dataOffset + uint64_t(info.chunkBegin(c)) * info.texelBytes();
  }
};

/// Total file size a store with this header will have (for the disk estimate).
uint64_t btfFileBytes(const BtfInfo& info);

class BtfWriter {
 public:
  /// Opens `path`.partial. With resume, an existing partial must have the identical header
  /// (same scene, settings and layout), else btf::Error says so; its finished chunks are
  /// verified and kept. Without resume any partial is started over.
  BtfWriter(const std::string& path, const BtfInfo& info, bool resume);
  /// Another rank's view of the partial that rank 0 created or resumed (docs/cluster.md): opens
  /// it for writing chunks without touching its header, table or VMF; which chunks are done
  /// comes from rank 0 (setDone). Never finishes: rank 0 does (finishShared).
  struct Attach {};
  BtfWriter(const std::string& path, const BtfInfo& info, Attach);
  ~BtfWriter();
  BtfWriter(const BtfWriter&) = delete;
  BtfWriter& operator=(const BtfWriter&) = delete;

  bool chunkDone(int c) const { return m_done[size_t(c)] != 0; }
  /// One byte per chunk, 1 when done (what rank 0 sends to the others).
  const std::vector<uint8_t>& doneFlags() const { return m_done; }
  void setDone(const std::vector<uint8_t>& done);
  int chunksDone() const;
  bool resumed() const { return m_resumed; }
  /// What resuming found, when it was not a clean resume (a truncated or unreadable .partial):
  /// one line for the user; empty otherwise.
  const std::string& resumeNote() const { return m_resumeNote; }
  /// VMF of all directions: nDirs × nu × nv × 2 floats (coverage, mean depth).
  void writeVmf(const std::vector<float>& vmf);
  /// Writes a chunk's data and then marks it done in the table.
  void writeChunk(int c, const float* data);
  /// Flushes, then renames the partial onto the final path (atomic replace).
  void finish();
  /// finish() after other processes wrote chunks into the same partial: the table is read back
  /// from the file and every chunk must be marked done there.
  void finishShared();
  const std::string& partialPath() const { return m_partial; }

 private:
  void pwriteAll(const void* data, uint64_t bytes, uint64_t offset);
  std::string m_path, m_partial;
  BtfInfo m_info;
  BtfLayout m_layout;
  int m_fd = -1;
  std::vector<uint8_t> m_done;  // bytes, not bits: a background writer marks chunks done
  bool m_resumed = false;
  bool m_finished = false;
  std::string m_resumeNote;
};

class BtfReader {
 public:
  explicit BtfReader(const std::string& path);
  ~BtfReader();
  BtfReader(const BtfReader&) = delete;
  BtfReader& operator=(const BtfReader&) = delete;

  const BtfInfo& info() const { return m_info; }
  const BtfLayout& layout() const { return m_layout; }
  const std::string& headerJson() const { return m_headerJson; }
  /// One chunk, checksum verified (btf::Error on mismatch).
  std::vector<float> readChunk(int c) const;
  /// All views × lights of one texel: out[(v * nL + l) * 3 + c].
  std::vector<float> readTexel(int64_t texel) const;
  /// Same into a caller's buffer of nDirs² · 3 floats (no chunk checksum: use verify()).
  void readTexelInto(int64_t texel, float* out) const;
  /// One RGB value (12 bytes).
  void readValue(int64_t texel, int view, int light, float rgb[3]) const;
  /// One (view, light) image: nu × nv RGB, row-major from (u, v) = (0, 0).
  std::vector<float> readImage(int view, int light) const;
  /// VMF of one direction: nu × nv × (coverage, mean depth).
  std::vector<float> readVmf(int dir) const;
  /// Every direction's map, one after the other (nDirs × texels × 2); non-finite entries → 0.
  std::vector<float> readVmfAll() const;
  struct Verification {
    int chunks = 0;
    std::vector<int> badChunks;
    bool vmfOk = true;
  };
  /// Reads everything and checks every checksum.
  Verification verify() const;
  /// Streams chunk c through its checksum (8 MiB at a time, nothing kept); throws btf::Error
  /// "PATH: chunk C checksum mismatch …" when it differs.
  void verifyChunk(int c) const;

 private:
  void preadAll(void* data, uint64_t bytes, uint64_t offset) const;
  std::string m_path;
  int m_fd = -1;
  BtfInfo m_info;
  BtfLayout m_layout;
  std::string m_headerJson;
  std::vector<uint64_t> m_checksums;
};

}  // namespace btf
