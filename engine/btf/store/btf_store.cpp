#include <btf/core/container.h>
#include <btf/core/error.h>
#include <btf/core/hash.h>
#include <btf/core/input_file.h>
#include <btf/core/json_limits.h>
#include <btf/core/math.h>
#include <btf/directions/direction_set.h>
#include <btf/store/btf_store.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

namespace btf {

namespace {

constexpr container::Magic kMagic = {'B', 'T', 'F', 'S', 'T', 'O', 'R', '1'};
constexpr int kFormatVersion = 1;
using container::alignUp;

struct TableEntry {
  uint64_t checksum;
  uint64_t state;  // kDone when the chunk's data is complete
};
constexpr uint64_t kDone = 0x454e4f44u;  // "DONE"

std::string sysError(const std::string& path, const std::string& what) {
  return path + ": " + what + " (" + std::strerror(errno) + ")";
}

}  // namespace

std::string infoToJson(const BtfInfo& i) {
  nlohmann::ordered_json j;
  j["format"] = "btfstudio-raw-btf";
  j["format_version"] = kFormatVersion;
  j["convention"] =
      "aBRDF(u,v,wi,wo) = Lo / (E_perp cos(theta_i)) in 1/sr, RGB float32 little-endian; theta "
      "from +z, phi from +x counter-clockwise, degrees; wi toward the light, wo toward the camera; "
      "texel (u,v) ray passes through ((u+0.5)Lx/Nu, (v+0.5)Ly/Nv, 0); layout "
      "[texel][view][light][rgb], texel = u + Nu*v";
  j["texels"] = {i.nu, i.nv};
  j["tile_size"] = {i.Lx, i.Ly};
  j["directions"]["set"] = i.directionSet;
  j["directions"]["theta_phi_deg"] = i.dirsDeg;
  j["chunk_texels"] = i.chunkTexels;
  j["settings"]["spp"] = i.spp;
  j["settings"]["shadows"] = i.shadows;
  j["settings"]["shadow_bias"] = i.shadowBias;
  j["settings"]["seed"] = i.seed;
  j["settings"]["vmf"] = i.hasVmf;
  j["scene"]["name"] = i.sceneName;
  j["scene"]["hash"] = i.sceneHash;
  j["scene"]["json"] = i.sceneJson;
  j["plan"] = i.plan;
  j["vmf"] =
      "per direction, per texel: (coverage in [0,1], mean signed hit distance to the "
      "reference plane along the direction), float32";
  return j.dump(1);
}

BtfInfo infoFromJson(const std::string& text, const std::string& file) {
  checkJsonDepth(text, file + " (header)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception&) {
    throw Error(file + ": malformed BTF header (not valid JSON)");
  }
  if (!j.is_object()) throw Error(file + ": malformed BTF header (not a JSON object)");
  const JsonFields h(j, file);
  if (h.string("/format") != "btfstudio-raw-btf") throw Error(file + ": not a raw BTF header");
  if (h.integer("/format_version", 0, 1 << 30) != kFormatVersion)
    throw Error(file + ": unsupported store version " + j.at("format_version").dump());
  BtfInfo i;
  // Bounds: texels as --texels allows; directions up to a 256×256 grid (65 536 directions);
  // everything sized from them is then checked against the file's actual size by the reader.
  i.nu = int(h.integer("/texels/0", 1, 16384));
  i.nv = int(h.integer("/texels/1", 1, 16384));
  i.Lx = h.number("/tile_size/0");
  i.Ly = h.number("/tile_size/1");
  if (!(i.Lx > 0) || !(i.Ly > 0)) h.fail("/tile_size", "periods must be positive");
  i.directionSet = h.string("/directions/set");
  const auto& dirs = h.at("/directions/theta_phi_deg");
  if (!dirs.is_array() || dirs.empty() || dirs.size() > 65536)
    h.fail("/directions/theta_phi_deg", "must be a list of 1..65536 (θ, φ) pairs");
  // The angles are those of the named set, direction by direction (within 1e-6°): decoders
  // interpolate with the set, exports write the angles, and the two must agree.
  DirectionSet set;
  try {
    set = DirectionSet::fromName(i.directionSet);
  } catch (const Error& e) {
    h.fail("/directions/set", e.what());
  }
  if (size_t(set.size()) != dirs.size())
    h.fail("/directions/theta_phi_deg", "lists " + std::to_string(dirs.size()) +
                                            " directions; the set '" + i.directionSet + "' has " +
                                            std::to_string(set.size()));
  for (size_t k = 0; k < dirs.size(); ++k) {
    const std::string p = "/directions/theta_phi_deg/" + std::to_string(k);
    const double t = h.number(p + "/0"), ph = h.number(p + "/1");
    const Direction& d = set[int(k)];
    double dphi = std::fmod(std::abs(ph - rad2deg(d.phi)), 360.0);
    dphi = std::min(dphi, 360.0 - dphi);
    if (!(std::abs(t - rad2deg(d.theta)) <= 1e-6) || !(dphi <= 1e-6 || d.theta == 0))
      h.fail(p, "is not direction " + std::to_string(k) + " of the set '" + i.directionSet + "'");
    i.dirsDeg.push_back({t, ph});
  }
  i.chunkTexels = int(h.integer("/chunk_texels", 1, 1 << 30));  // may exceed the texels
  i.spp = int(h.integer("/settings/spp", 1, 64));
  i.shadows = h.string("/settings/shadows");
  i.shadowBias = h.number("/settings/shadow_bias");
  i.seed = uint64_t(h.integer("/settings/seed", 0, std::numeric_limits<int64_t>::max()));
  i.hasVmf = h.boolean("/settings/vmf", true);
  i.sceneName = h.string("/scene/name");
  i.sceneHash = h.string("/scene/hash");
  i.sceneJson = h.string("/scene/json");
  i.plan = h.string("/plan");
  return i;
}

BtfLayout BtfLayout::of(const BtfInfo& info, uint64_t headerJsonBytes) {
  BtfLayout l;
  l.headerBytes = headerJsonBytes;
  l.tableOffset = alignUp(24 + headerJsonBytes, 64);
  l.vmfOffset = alignUp(l.tableOffset + sizeof(TableEntry) * uint64_t(info.chunks()), 4096);
  l.vmfBytes =
      info.hasVmf ? uint64_t(info.nDirs()) * uint64_t(info.texels()) * 2 * sizeof(float) : 0;
  l.dataOffset = alignUp(l.vmfOffset + l.vmfBytes + 8, 4096);
  l.totalBytes = l.dataOffset + uint64_t(info.texels()) * info.texelBytes();
  return l;
}

uint64_t btfFileBytes(const BtfInfo& info) {
  return BtfLayout::of(info, infoToJson(info).size()).totalBytes;
}

// ---------------------------------------------------------------- writer

BtfWriter::BtfWriter(const std::string& path, const BtfInfo& info, bool resume)
    : m_path(path), m_partial(path + ".partial"), m_info(info) {
  const std::string header = infoToJson(info);
  m_layout = BtfLayout::of(info, header.size());
  m_done.assign(size_t(info.chunks()), false);
  const bool exists = std::filesystem::exists(m_partial);
  // The partial's own header, read alone (a truncated file still has it): "" when unreadable.
  auto partialHeader = [&]() -> std::string {
    std::ifstream f(m_partial, std::ios::binary);
    char first[container::kPreambleBytes] = {};
    if (!f.read(first, sizeof first)) return "";
    try {
      const auto pre = container::parsePreamble(first, std::filesystem::file_size(m_partial),
                                                kMagic, m_partial, "BTF store");
      std::string h(pre.headerBytes, '\0');
      if (!f.read(h.data(), std::streamsize(h.size()))) return "";
      container::checkHeader(h, pre, m_partial);
      return h;
    } catch (const Error&) {
      return "";
    }
  };
  const std::string found = resume && exists ? partialHeader() : std::string();
  if (resume && exists && found.empty())
    m_resumeNote = m_partial + " was unreadable (cut short inside its header): starting over";
  if (resume && exists && !found.empty()) {
    // Reuse the partial only if it was made by the very same job.
    if (found != header)
      throw Error(m_partial +
                  ": cannot resume: it was made with a different scene or settings "
                  "(rerun without --resume to start over)");
    m_fd = ::open(m_partial.c_str(), O_RDWR);
    if (m_fd < 0) throw Error(sysError(m_partial, "cannot open for resuming"));
    const uint64_t size = std::filesystem::file_size(m_partial);
    if (size != m_layout.totalBytes) {
      // Cut short (a full disk, a killed copy): back to its size; chunks past the cut fail
      // their checksums below and are recomputed.
      if (::ftruncate(m_fd, off_t(m_layout.totalBytes)) != 0)
        throw Error(sysError(m_partial, "cannot restore the size of the truncated partial"));
      m_resumeNote = m_partial + " was truncated (" + std::to_string(size) + " of " +
                     std::to_string(m_layout.totalBytes) +
                     " bytes): resuming from the chunks it still holds";
    }
    std::vector<TableEntry> table(size_t(info.chunks()));
    if (::pread(m_fd, table.data(), table.size() * sizeof(TableEntry),
                off_t(m_layout.tableOffset)) != ssize_t(table.size() * sizeof(TableEntry)))
      throw Error(sysError(m_partial, "cannot read chunk table"));
    std::vector<char> buf;
    for (int c = 0; c < info.chunks(); ++c) {
      if (table[size_t(c)].state != kDone) continue;
      const uint64_t bytes = uint64_t(info.chunkEnd(c) - info.chunkBegin(c)) * info.texelBytes();
      buf.resize(bytes);
      if (::pread(m_fd, buf.data(), bytes, off_t(m_layout.chunkOffset(info, c))) ==
              ssize_t(bytes) &&
          checksum64(buf.data(), bytes) == table[size_t(c)].checksum)
        m_done[size_t(c)] = 1;  // verified: keep it
    }
    m_resumed = true;
    return;
  }
  std::filesystem::path dir = std::filesystem::path(m_partial).parent_path();
  if (!dir.empty() && !std::filesystem::exists(dir)) std::filesystem::create_directories(dir);
  m_fd = ::open(m_partial.c_str(), O_RDWR | O_CREAT | O_TRUNC, 0644);
  if (m_fd < 0) throw Error(sysError(m_partial, "cannot create"));
  if (::ftruncate(m_fd, off_t(m_layout.totalBytes)) != 0)
    throw Error(sysError(
        m_partial, "cannot size the file to " + std::to_string(m_layout.totalBytes) + " bytes"));
  const auto pre = container::preamble(kMagic, header);
  pwriteAll(pre.data(), pre.size(), 0);
  pwriteAll(header.data(), header.size(), 24);
  std::vector<TableEntry> table(size_t(info.chunks()), TableEntry{0, 0});
  pwriteAll(table.data(), table.size() * sizeof(TableEntry), m_layout.tableOffset);
}

BtfWriter::BtfWriter(const std::string& path, const BtfInfo& info, Attach)
    : m_path(path), m_partial(path + ".partial"), m_info(info) {
  const std::string header = infoToJson(info);
  m_layout = BtfLayout::of(info, header.size());
  m_done.assign(size_t(info.chunks()), 0);
  m_fd = ::open(m_partial.c_str(), O_RDWR);
  if (m_fd < 0) throw Error(sysError(m_partial, "cannot open the job's partial file"));
  std::string found(header.size(), '\0');
  if (::pread(m_fd, found.data(), found.size(), 24) != ssize_t(found.size()) || found != header)
    throw Error(m_partial +
                ": its header differs from this rank's job (another scene or settings, or the "
                "file system does not show rank 0's file to this node)");
  m_resumed = true;
}

void BtfWriter::setDone(const std::vector<uint8_t>& done) {
  BTF_CHECK(done.size() == m_done.size());
  m_done = done;
}

void BtfWriter::finishShared() {
  std::vector<TableEntry> table(m_done.size());
  if (::pread(m_fd, table.data(), table.size() * sizeof(TableEntry), off_t(m_layout.tableOffset)) !=
      ssize_t(table.size() * sizeof(TableEntry)))
    throw Error(sysError(m_partial, "cannot read back the chunk table"));
  for (size_t c = 0; c < table.size(); ++c) {
    if (table[c].state != kDone)
      throw Error(m_partial + ": cannot finish: chunk " + std::to_string(c) +
                  " was not written by any rank");
    m_done[c] = 1;
  }
  finish();
}

BtfWriter::~BtfWriter() {
  if (m_fd >= 0) ::close(m_fd);
}

int BtfWriter::chunksDone() const {
  int n = 0;
  for (bool d : m_done) n += d;
  return n;
}

void BtfWriter::pwriteAll(const void* data, uint64_t bytes, uint64_t offset) {
  const char* p = static_cast<const char*>(data);
  while (bytes > 0) {
    const ssize_t w = ::pwrite(m_fd, p, std::min<uint64_t>(bytes, 1u << 30), off_t(offset));
    if (w < 0) {
      if (errno == EINTR) continue;
      throw Error(sysError(m_partial, "write failed"));
    }
    p += w;
    bytes -= uint64_t(w);
    offset += uint64_t(w);
  }
}

void BtfWriter::writeVmf(const std::vector<float>& vmf) {
  BTF_CHECK(vmf.size() * sizeof(float) == m_layout.vmfBytes);
  for (float v : vmf) BTF_CHECK_MSG(std::isfinite(v), "non-finite VMF value");
  pwriteAll(vmf.data(), m_layout.vmfBytes, m_layout.vmfOffset);
  const uint64_t sum = checksum64(vmf.data(), m_layout.vmfBytes);
  pwriteAll(&sum, 8, m_layout.vmfOffset + m_layout.vmfBytes);
}

void BtfWriter::writeChunk(int c, const float* data) {
  const uint64_t bytes = uint64_t(m_info.chunkEnd(c) - m_info.chunkBegin(c)) * m_info.texelBytes();
  for (uint64_t k = 0; k < bytes / sizeof(float); ++k)
    BTF_CHECK_MSG(std::isfinite(data[k]), "non-finite aBRDF value about to be written");
  pwriteAll(data, bytes, m_layout.chunkOffset(m_info, c));
  // Data first, then its table entry: a kill in between leaves the chunk pending.
  if (::fdatasync(m_fd) != 0) throw Error(sysError(m_partial, "fdatasync failed"));
  const TableEntry e{checksum64(data, bytes), kDone};
  pwriteAll(&e, sizeof e, m_layout.tableOffset + sizeof(TableEntry) * uint64_t(c));
  m_done[size_t(c)] = 1;
}

void BtfWriter::finish() {
  for (size_t c = 0; c < m_done.size(); ++c)
    if (!m_done[c])
      throw Error(m_partial + ": cannot finish: chunk " + std::to_string(c) + " missing");
  if (::fsync(m_fd) != 0) throw Error(sysError(m_partial, "fsync failed"));
  ::close(m_fd);
  m_fd = -1;
  if (std::rename(m_partial.c_str(), m_path.c_str()) != 0)
    throw Error(sysError(m_path, "cannot rename the finished partial file into place"));
  m_finished = true;
}

// ---------------------------------------------------------------- reader

BtfReader::BtfReader(const std::string& path) : m_path(path) {
  checkInputFile(path, "BTF");
  m_fd = ::open(path.c_str(), O_RDONLY);
  if (m_fd < 0) throw Error(sysError(path, "cannot open BTF"));
  struct stat st;
  if (::fstat(m_fd, &st) != 0) throw Error(sysError(path, "cannot stat"));
  const uint64_t size = uint64_t(st.st_size);
  char first[container::kPreambleBytes] = {};
  if (size >= sizeof first) preadAll(first, sizeof first, 0);
  const container::Preamble pre = container::parsePreamble(first, size, kMagic, path, "BTF store");
  const uint64_t hlen = pre.headerBytes;
  m_headerJson.resize(hlen);
  preadAll(m_headerJson.data(), hlen, 24);
  container::checkHeader(m_headerJson, pre, path);
  m_info = infoFromJson(m_headerJson, path);
  m_layout = BtfLayout::of(m_info, hlen);
  if (size != m_layout.totalBytes)
    throw Error(path + ": truncated or padded file: expected " +
                std::to_string(m_layout.totalBytes) + " bytes, found " + std::to_string(size));
  std::vector<TableEntry> table(size_t(m_info.chunks()));
  preadAll(table.data(), table.size() * sizeof(TableEntry), m_layout.tableOffset);
  for (const auto& e : table) m_checksums.push_back(e.state == kDone ? e.checksum : 0);
}

BtfReader::~BtfReader() {
  if (m_fd >= 0) ::close(m_fd);
}

void BtfReader::preadAll(void* data, uint64_t bytes, uint64_t offset) const {
  char* p = static_cast<char*>(data);
  while (bytes > 0) {
    const ssize_t r = ::pread(m_fd, p, std::min<uint64_t>(bytes, 1u << 30), off_t(offset));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0)
      throw Error(m_path + ": read failed or file truncated at offset " + std::to_string(offset));
    p += r;
    bytes -= uint64_t(r);
    offset += uint64_t(r);
  }
}

std::vector<float> BtfReader::readChunk(int c) const {
  if (c < 0 || c >= m_info.chunks()) throw Error(m_path + ": chunk index out of range");
  const uint64_t bytes = uint64_t(m_info.chunkEnd(c) - m_info.chunkBegin(c)) * m_info.texelBytes();
  std::vector<float> out(bytes / sizeof(float));
  preadAll(out.data(), bytes, m_layout.chunkOffset(m_info, c));
  if (checksum64(out.data(), bytes) != m_checksums[size_t(c)])
    throw Error(m_path + ": chunk " + std::to_string(c) +
                " checksum mismatch (corrupted or incomplete data)");
  return out;
}

std::vector<float> BtfReader::readTexel(int64_t t) const {
  if (t < 0 || t >= m_info.texels()) throw Error(m_path + ": texel index out of range");
  std::vector<float> out(m_info.texelBytes() / sizeof(float));
  preadAll(out.data(), m_info.texelBytes(),
           m_layout.dataOffset + uint64_t(t) * m_info.texelBytes());
  return out;
}

void BtfReader::readTexelInto(int64_t t, float* out) const {
  if (t < 0 || t >= m_info.texels()) throw Error(m_path + ": texel index out of range");
  preadAll(out, m_info.texelBytes(), m_layout.dataOffset + uint64_t(t) * m_info.texelBytes());
}

void BtfReader::readValue(int64_t t, int view, int light, float rgb[3]) const {
  const int n = m_info.nDirs();
  if (t < 0 || t >= m_info.texels() || view < 0 || view >= n || light < 0 || light >= n)
    throw Error(m_path + ": value index out of range");
  preadAll(rgb, 12,
           m_layout.dataOffset + uint64_t(t) * m_info.texelBytes() +
               (uint64_t(view) * uint64_t(n) + uint64_t(light)) * 12);
}

std::vector<float> BtfReader::readImage(int view, int light) const {
  const int n = m_info.nDirs();
  if (view < 0 || view >= n || light < 0 || light >= n)
    throw Error(m_path + ": direction index out of range");
  std::vector<float> out(size_t(m_info.texels()) * 3);
  const uint64_t within = (uint64_t(view) * n + uint64_t(light)) * 3 * sizeof(float);
  for (int64_t t = 0; t < m_info.texels(); ++t)
    preadAll(&out[size_t(t) * 3], 3 * sizeof(float),
             m_layout.dataOffset + uint64_t(t) * m_info.texelBytes() + within);
  return out;
}

std::vector<float> BtfReader::readVmf(int dir) const {
  if (dir < 0 || dir >= m_info.nDirs()) throw Error(m_path + ": direction index out of range");
  if (!m_info.hasVmf)
    throw Error(m_path +
                ": this BTF has no visibility map (the effect plan dropped it: flat tile)");
  std::vector<float> out(size_t(m_info.texels()) * 2);
  preadAll(out.data(), out.size() * sizeof(float),
           m_layout.vmfOffset + uint64_t(dir) * uint64_t(m_info.texels()) * 2 * sizeof(float));
  return out;
}

std::vector<float> BtfReader::readVmfAll() const {
  std::vector<float> all;
  all.reserve(size_t(m_info.nDirs()) * size_t(m_info.texels()) * 2);
  for (int d = 0; d < m_info.nDirs(); ++d) {
    std::vector<float> v = readVmf(d);
    for (float& x : v)
      if (!std::isfinite(x)) x = 0;
    all.insert(all.end(), v.begin(), v.end());
  }
  return all;
}

void BtfReader::verifyChunk(int c) const {
  if (c < 0 || c >= m_info.chunks()) throw Error(m_path + ": chunk index out of range");
  const uint64_t bytes = uint64_t(m_info.chunkEnd(c) - m_info.chunkBegin(c)) * m_info.texelBytes();
  const uint64_t off = m_layout.chunkOffset(m_info, c);
  std::vector<char> buf(size_t(std::min<uint64_t>(bytes, uint64_t(8) << 20)));
  Checksum64 sum;
  for (uint64_t done = 0; done < bytes;) {
    const uint64_t n = std::min<uint64_t>(buf.size(), bytes - done);
    preadAll(buf.data(), n, off + done);
    sum.update(buf.data(), size_t(n));
    done += n;
  }
  if (sum.finish() != m_checksums[size_t(c)])
    throw Error(m_path + ": chunk " + std::to_string(c) +
                " checksum mismatch (corrupted or incomplete data)");
}

BtfReader::Verification BtfReader::verify() const {
  Verification v;
  v.chunks = m_info.chunks();
  for (int c = 0; c < m_info.chunks(); ++c) {
    try {
      verifyChunk(c);
    } catch (const Error&) {
      v.badChunks.push_back(c);
    }
  }
  std::vector<float> vmf(m_layout.vmfBytes / sizeof(float));
  uint64_t sum = 0;
  preadAll(vmf.data(), m_layout.vmfBytes, m_layout.vmfOffset);
  preadAll(&sum, 8, m_layout.vmfOffset + m_layout.vmfBytes);
  v.vmfOk = checksum64(vmf.data(), m_layout.vmfBytes) == sum;
  return v;
}

}  // namespace btf
