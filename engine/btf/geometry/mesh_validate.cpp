#include <btf/core/error.h>
#include <btf/geometry/mesh_validate.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string_view>
#include <vector>

namespace btf {

namespace {

/// Most vertices one polygon may list: far beyond any real cage, small enough that a flipped
/// count byte is caught as such rather than read as a giant face.
constexpr uint64_t kMaxFaceVertices = 1u << 16;

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// Whitespace-separated tokens of a text body, with the line of each (for errors).
class Tokens {
 public:
  Tokens(std::string_view text, size_t pos, int line) : m_t(text), m_p(pos), m_line(line) {}
  bool next(std::string_view& tok) {
    while (m_p < m_t.size() && std::isspace(static_cast<unsigned char>(m_t[m_p]))) {
      if (m_t[m_p] == '\n') ++m_line;
      ++m_p;
    }
    if (m_p >= m_t.size()) return false;
    const size_t b = m_p;
    while (m_p < m_t.size() && !std::isspace(static_cast<unsigned char>(m_t[m_p]))) ++m_p;
    tok = m_t.substr(b, m_p - b);
    return true;
  }
  int line() const { return m_line; }

 private:
  std::string_view m_t;
  size_t m_p;
  int m_line;
};

bool parseDouble(std::string_view tok, double& v) {
  if (tok.empty() || tok.size() > 64) return false;
  char buf[65];
  std::memcpy(buf, tok.data(), tok.size());
  buf[tok.size()] = 0;
  char* end = nullptr;
  v = std::strtod(buf, &end);
  return end == buf + tok.size();
}

bool parseInteger(std::string_view tok, int64_t& v) {
  double d;
  if (!parseDouble(tok, d) || !std::isfinite(d) || d != std::floor(d) || std::abs(d) > 9e15)
    return false;
  v = int64_t(d);
  return true;
}

/// The refusal of a well-formed mesh that is too large (counted as far as it was read).
[[noreturn]] void tooMany(const std::string& path, const MeshFileCounts& c, uint64_t maxTriangles) {
  throw Error(path + ": the mesh's first " + std::to_string(c.faces) + " faces already make " +
              std::to_string(c.triangles) + " triangles, more than the " +
              std::to_string(maxTriangles) + " the memory budget allows");
}

// ------------------------------------------------------------------------------------ PLY

enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

bool plyType(const std::string& s, PlyType& t) {
  static const std::pair<const char*, PlyType> names[] = {
      {"char", PlyType::I8},    {"int8", PlyType::I8},     {"uchar", PlyType::U8},
      {"uint8", PlyType::U8},   {"short", PlyType::I16},   {"int16", PlyType::I16},
      {"ushort", PlyType::U16}, {"uint16", PlyType::U16},  {"int", PlyType::I32},
      {"int32", PlyType::I32},  {"uint", PlyType::U32},    {"uint32", PlyType::U32},
      {"float", PlyType::F32},  {"float32", PlyType::F32}, {"double", PlyType::F64},
      {"float64", PlyType::F64}};
  for (const auto& [n, ty] : names)
    if (s == n) {
      t = ty;
      return true;
    }
  return false;
}

size_t plySize(PlyType t) {
  switch (t) {
    case PlyType::I8:
    case PlyType::U8:
      return 1;
    case PlyType::I16:
    case PlyType::U16:
      return 2;
    case PlyType::I32:
    case PlyType::U32:
    case PlyType::F32:
      return 4;
    case PlyType::F64:
      return 8;
  }
  return 1;
}

bool plyInteger(PlyType t) {
  return t != PlyType::F32 && t != PlyType::F64;
}

struct PlyProperty {
  std::string name;
  bool list = false;
  PlyType count = PlyType::U8, type = PlyType::F32;
};
struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> props;
};

/// Reads PLY scalars from a binary body (bounds-checked) or an ASCII one (token by token).
class PlyBody {
 public:
  PlyBody(const std::string& path, std::string_view bytes, size_t pos, int line, int format)
      : m_path(path), m_b(bytes), m_p(pos), m_format(format), m_tok(bytes, pos, line) {}
  double read(PlyType t, const std::string& where) {
    if (m_format == 0) {
      std::string_view tok;
      double v;
      if (!m_tok.next(tok)) fail(where, "ends before this value (truncated file)");
      if (!parseDouble(tok, v))
        fail(where, "'" + std::string(tok.substr(0, 32)) + "' is not a number");
      if (plyInteger(t) && (v != std::floor(v) || !std::isfinite(v)))
        fail(where, "'" + std::string(tok.substr(0, 32)) + "' is not an integer");
      return v;
    }
    const size_t n = plySize(t);
    if (m_p + n > m_b.size()) fail(where, "ends past the end of the file (truncated file)");
    unsigned char raw[8];
    std::memcpy(raw, m_b.data() + m_p, n);
    m_p += n;
    if (m_format == 2) std::reverse(raw, raw + n);  // big endian
    switch (t) {
      case PlyType::I8:
        return double(int8_t(raw[0]));
      case PlyType::U8:
        return double(raw[0]);
      case PlyType::I16: {
        int16_t v;
        std::memcpy(&v, raw, 2);
        return v;
      }
      case PlyType::U16: {
        uint16_t v;
        std::memcpy(&v, raw, 2);
        return v;
      }
      case PlyType::I32: {
        int32_t v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case PlyType::U32: {
        uint32_t v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case PlyType::F32: {
        float v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case PlyType::F64: {
        double v;
        std::memcpy(&v, raw, 8);
        return v;
      }
    }
    return 0;
  }
  /// Bytes left in a binary body (ASCII: characters left, an upper bound on values).
  uint64_t left() const { return m_p <= m_b.size() ? m_b.size() - m_p : 0; }
  [[noreturn]] void fail(const std::string& where, const std::string& rule) const {
    throw Error(m_path + ": malformed PLY: " + where + " " + rule);
  }

 private:
  const std::string& m_path;
  std::string_view m_b;
  size_t m_p;
  int m_format;  // 0 ascii, 1 binary little endian, 2 binary big endian
  Tokens m_tok;
};

MeshFileCounts validatePly(const std::string& path, std::string_view b, uint64_t maxTriangles) {
  auto fail = [&](int line, const std::string& what) -> void {
    throw Error(path + ":" + std::to_string(line) + ": malformed PLY header: " + what);
  };
  // The header: lines up to "end_header", at most 1 MiB.
  size_t pos = 0;
  int line = 0, format = -1;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (pos < b.size() && pos < (1u << 20)) {
    size_t eol = b.find('\n', pos);
    if (eol == std::string_view::npos) eol = b.size();
    std::string l(b.substr(pos, eol - pos));
    pos = std::min(b.size(), eol + 1);
    ++line;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    // Header lines are printable ASCII: OpenMesh's header parser loops without end on some
    // binary garbage, so nothing else reaches it.
    for (char ch : l)
      if (static_cast<unsigned char>(ch) < 32 && ch != '\t')
        fail(line, "a control or binary byte in the header");
      else if (static_cast<unsigned char>(ch) >= 127)
        fail(line, "a non-ASCII byte in the header");
    std::vector<std::string> w;
    Tokens t(l, 0, line);
    std::string_view tok;
    while (t.next(tok)) w.emplace_back(tok);
    if (line == 1) {
      if (w.size() != 1 || w[0] != "ply") fail(line, "the first line must be 'ply'");
      continue;
    }
    if (w.empty()) continue;
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "format") {
      if (w.size() != 3 || w[2] != "1.0") fail(line, "expected 'format KIND 1.0'");
      if (w[1] == "ascii")
        format = 0;
      else if (w[1] == "binary_little_endian")
        format = 1;
      else if (w[1] == "binary_big_endian")
        format = 2;
      else
        fail(line, "unknown format '" + w[1].substr(0, 32) + "'");
      continue;
    }
    if (w[0] == "element") {
      int64_t n = -1;
      if (w.size() != 3 || !parseInteger(w[2], n) || n < 0)
        fail(line, "'element NAME COUNT' needs a count >= 0");
      // Every element takes at least one byte (a binary scalar, or a digit and a separator).
      if (uint64_t(n) > b.size())
        fail(line, "element '" + w[1].substr(0, 32) + "' counts " + std::to_string(n) +
                       " items, more than the file's " + std::to_string(b.size()) + " bytes hold");
      elements.push_back({w[1], uint64_t(n), {}});
      continue;
    }
    if (w[0] == "property") {
      if (elements.empty()) fail(line, "property before any element");
      PlyProperty p;
      if (w.size() == 5 && w[1] == "list") {
        p.list = true;
        if (!plyType(w[2], p.count) || !plyType(w[3], p.type) || !plyInteger(p.count))
          fail(line, "list property needs an integer count type and a value type");
        p.name = w[4];
      } else if (w.size() == 3) {
        if (!plyType(w[1], p.type))
          fail(line, "unknown property type '" + w[1].substr(0, 32) + "'");
        p.name = w[2];
      } else {
        fail(line, "'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'");
      }
      elements.back().props.push_back(p);
      continue;
    }
    if (w[0] == "end_header") {
      ended = true;
      break;
    }
    fail(line, "unknown keyword '" + w[0].substr(0, 32) + "'");
  }
  if (!ended) fail(line, "no 'end_header' line");
  if (format < 0) fail(line, "no 'format' line");

  MeshFileCounts counts;
  const PlyElement* vertexEl = nullptr;
  for (const auto& e : elements) {
    if (e.count > 0 && e.props.empty())
      fail(line, "element '" + e.name.substr(0, 32) + "' has items but no properties");
    if (e.name == "vertex") vertexEl = &e;
    if (e.name == "face" && std::none_of(e.props.begin(), e.props.end(), [](const PlyProperty& p) {
          return p.list && (p.name == "vertex_indices" || p.name == "vertex_index");
        }))
      fail(line, "the face element has no 'vertex_indices' list");
  }
  if (!vertexEl) fail(line, "no 'vertex' element");
  for (const char* axis : {"x", "y", "z"})
    if (std::none_of(vertexEl->props.begin(), vertexEl->props.end(),
                     [&](const PlyProperty& p) { return p.name == axis && !p.list; }))
      fail(line, std::string("the vertex element has no '") + axis + "' property");
  counts.vertices = vertexEl->count;

  PlyBody body(path, b, pos, line, format);
  for (const auto& e : elements) {
    const bool isVertex = e.name == "vertex", isFace = e.name == "face";
    for (uint64_t i = 0; i < e.count; ++i) {
      for (const auto& p : e.props) {
        const std::string where = "element '" + e.name.substr(0, 32) + "' item " +
                                  std::to_string(i) + " property '" + p.name.substr(0, 32) + "'";
        if (!p.list) {
          const double v = body.read(p.type, where);
          if (isVertex && (p.name == "x" || p.name == "y" || p.name == "z") && !std::isfinite(v))
            body.fail(where, "is not a finite coordinate");
          continue;
        }
        const double n = body.read(p.count, where + " (list length)");
        const bool indices = isFace && (p.name == "vertex_indices" || p.name == "vertex_index");
        if (n < 0 || uint64_t(n) > kMaxFaceVertices || uint64_t(n) * plySize(p.type) > body.left())
          body.fail(where, "has a list length of " + std::to_string(int64_t(n)) +
                               " (more than the file holds or than " +
                               std::to_string(kMaxFaceVertices) + ")");
        if (indices && n < 3) body.fail(where, "lists fewer than 3 vertices");
        for (uint64_t k = 0; k < uint64_t(n); ++k) {
          const double v = body.read(p.type, where);
          if (indices && (!plyInteger(p.type) || v < 0 || v >= double(counts.vertices)))
            body.fail(where, "refers to vertex " + std::to_string(int64_t(v)) + ", outside 0.." +
                                 std::to_string(counts.vertices) + " - 1");
        }
        if (indices) {
          ++counts.faces;
          counts.triangles += uint64_t(n) - 2;
          if (counts.triangles > maxTriangles) tooMany(path, counts, maxTriangles);
        }
      }
    }
  }
  return counts;
}

// ------------------------------------------------------------------------------------ OBJ

MeshFileCounts validateObj(const std::string& path, std::string_view b, uint64_t maxTriangles) {
  MeshFileCounts counts;
  size_t pos = 0;
  int line = 0;
  auto fail = [&](const std::string& what) -> void {
    throw Error(path + ":" + std::to_string(line) + ": malformed OBJ: " + what);
  };
  while (pos < b.size()) {
    size_t eol = b.find('\n', pos);
    if (eol == std::string_view::npos) eol = b.size();
    const std::string_view l = b.substr(pos, eol - pos);
    pos = eol + 1;
    ++line;
    Tokens t(l, 0, line);
    std::string_view key, tok;
    if (!t.next(key)) continue;
    if (key == "mtllib") {
      // OpenMesh opens the material library next to the file: it must be a small regular file
      // (a device there would be read without end), or absent.
      std::string name(l.substr(l.find("mtllib") + 6));
      while (!name.empty() && std::isspace(static_cast<unsigned char>(name.front())))
        name.erase(0, 1);
      while (!name.empty() && std::isspace(static_cast<unsigned char>(name.back())))
        name.pop_back();
      const std::filesystem::path lib = std::filesystem::path(path).parent_path() / name;
      std::error_code ec;
      if (!name.empty() && std::filesystem::exists(lib, ec) &&
          (!std::filesystem::is_regular_file(lib, ec) ||
           std::filesystem::file_size(lib, ec) > (uint64_t(16) << 20)))
        fail("material library '" + name.substr(0, 64) +
             "' is not a regular file of at most 16 MiB");
    } else if (key == "v") {
      for (int k = 0; k < 3; ++k) {
        double v;
        if (!t.next(tok) || !parseDouble(tok, v)) fail("a vertex needs three numbers");
        if (!std::isfinite(v))
          fail("vertex " + std::to_string(counts.vertices + 1) + " has a non-finite coordinate");
      }
      ++counts.vertices;
    } else if (key == "f") {
      uint64_t n = 0;
      while (t.next(tok)) {
        int64_t idx;
        const std::string_view first = tok.substr(0, tok.find('/'));
        if (!parseInteger(first, idx) || idx == 0) fail("a face index must be a nonzero integer");
        // Negative indices count back from the last vertex so far.
        const int64_t abs = idx > 0 ? idx : int64_t(counts.vertices) + idx + 1;
        if (abs < 1 || uint64_t(abs) > counts.vertices)
          fail("face index " + std::to_string(idx) + " refers to no vertex (" +
               std::to_string(counts.vertices) + " defined so far)");
        if (++n > kMaxFaceVertices)
          fail("a face lists more than " + std::to_string(kMaxFaceVertices) + " vertices");
      }
      if (n < 3) fail("a face needs at least 3 vertices");
      ++counts.faces;
      counts.triangles += n - 2;
      if (counts.triangles > maxTriangles) tooMany(path, counts, maxTriangles);
    }
  }
  return counts;
}

// ------------------------------------------------------------------------------------ OFF

MeshFileCounts validateOff(const std::string& path, std::string_view b, uint64_t maxTriangles) {
  MeshFileCounts counts;
  // Header keyword: [ST][C][N][4][n]OFF, optionally followed by BINARY.
  Tokens t(b, 0, 1);
  std::string_view tok;
  auto fail = [&](const std::string& what) -> void {
    throw Error(path + ":" + std::to_string(t.line()) + ": malformed OFF: " + what);
  };
  if (!t.next(tok) || tok.size() < 3 || tok.substr(tok.size() - 3) != "OFF")
    fail("the file must start with OFF");
  // OpenMesh reads the header line its own way: a control character there (a form feed, a
  // vertical tab, a carriage return not ending the line) makes it read counts we never saw and
  // reserve for them (a fuzzer found 14 GB, then 9.6 GB).
  const std::string_view header = b.substr(0, b.find('\n'));
  for (size_t i = 0; i < header.size(); ++i) {
    const char ch = header[i];
    const bool crlf = ch == '\r' && i + 1 == header.size() && header.size() < b.size();
    if (static_cast<unsigned char>(ch) < 0x20 && ch != '\t' && !crlf)
      fail("a control character in the header line");
  }
  const std::string kind(tok);
  if (kind.find('4') != std::string::npos || kind.find("nOFF") != std::string::npos)
    fail("4-D and n-D OFF files are not supported");
  const int extra = (kind.find("ST") != std::string::npos ? 2 : 0) +
                    (kind.find('N') != std::string::npos ? 3 : 0);
  // Lines beginning with # are comments: read the rest token by token, skipping them.
  std::string body;
  {
    size_t pos = 0;
    int line = 0;
    while (pos < b.size()) {
      size_t eol = b.find('\n', pos);
      if (eol == std::string_view::npos) eol = b.size();
      std::string_view l = b.substr(pos, eol - pos);
      pos = eol + 1;
      if (line++ == 0) l = l.substr(std::min(l.size(), l.find("OFF") + 3));
      const size_t hash = l.find('#');
      body.append(l.substr(0, hash));
      body.push_back('\n');
    }
  }
  Tokens bt(body, 0, 1);
  if (bt.next(tok) && tok == "BINARY")
    throw Error(path + ": binary OFF files are not supported (convert the mesh to binary PLY)");
  bt = Tokens(body, 0, 1);
  auto integer = [&](const char* what) {
    int64_t v;
    if (!bt.next(tok) || !parseInteger(tok, v) || v < 0)
      throw Error(path + ":" + std::to_string(bt.line()) + ": malformed OFF: " + what +
                  " must be an integer >= 0");
    return v;
  };
  const int64_t nv = integer("the vertex count"), nf = integer("the face count");
  integer("the edge count");
  // A vertex takes at least three numbers of two characters each.
  if (uint64_t(nv) * 6 > b.size() || uint64_t(nf) * 8 > b.size())
    throw Error(path + ": malformed OFF: " + std::to_string(nv) + " vertices and " +
                std::to_string(nf) + " faces cannot fit in a " + std::to_string(b.size()) +
                "-byte file");
  counts.vertices = uint64_t(nv);
  for (int64_t i = 0; i < nv; ++i) {
    for (int k = 0; k < 3 + extra; ++k) {
      double v;
      if (!bt.next(tok) || !parseDouble(tok, v))
        throw Error(path + ":" + std::to_string(bt.line()) + ": malformed OFF: vertex " +
                    std::to_string(i) + " needs " + std::to_string(3 + extra) + " numbers");
      if (k < 3 && !std::isfinite(v))
        throw Error(path + ":" + std::to_string(bt.line()) + ": malformed OFF: vertex " +
                    std::to_string(i) + " has a non-finite coordinate");
    }
  }
  // Faces: n, then n indices; a colour may follow on the same line (skipped by line).
  const std::string_view rest(body);
  size_t pos = 0;
  int line = 1;
  {
    // Re-find the position after the vertices: walk the same tokens again with positions.
    Tokens w(body, 0, 1);
    for (int64_t k = 0; k < 3 + nv * (3 + extra); ++k) w.next(tok);
    pos = size_t(tok.data() + tok.size() - body.data());
    line = w.line();
  }
  for (int64_t f = 0; f < nf;) {
    if (pos >= rest.size())
      throw Error(path + ": malformed OFF: ends after " + std::to_string(f) + " of " +
                  std::to_string(nf) + " faces (truncated file)");
    size_t eol = rest.find('\n', pos);
    if (eol == std::string_view::npos) eol = rest.size();
    Tokens lt(rest.substr(pos, eol - pos), 0, line);
    pos = eol + 1;
    ++line;
    int64_t n;
    if (!lt.next(tok)) continue;  // blank line
    auto failF = [&](const std::string& what) {
      throw Error(path + ":" + std::to_string(line - 1) + ": malformed OFF: face " +
                  std::to_string(f) + " " + what);
    };
    if (!parseInteger(tok, n) || n < 3 || uint64_t(n) > kMaxFaceVertices)
      failF("needs a vertex count of at least 3");
    for (int64_t k = 0; k < n; ++k) {
      int64_t idx;
      if (!lt.next(tok) || !parseInteger(tok, idx)) failF("lists fewer indices than it counts");
      if (idx < 0 || idx >= nv)
        failF("refers to vertex " + std::to_string(idx) + ", outside 0.." + std::to_string(nv) +
              " - 1");
    }
    ++counts.faces;
    counts.triangles += uint64_t(n) - 2;
    if (counts.triangles > maxTriangles) tooMany(path, counts, maxTriangles);
    ++f;
  }
  return counts;
}

}  // namespace

MeshFileCounts validateMeshFile(const std::string& path, const std::string& bytes,
                                uint64_t maxTriangles) {
  const std::string ext = lower(std::filesystem::path(path).extension().string());
  if (ext == ".ply") return validatePly(path, bytes, maxTriangles);
  if (ext == ".obj") return validateObj(path, bytes, maxTriangles);
  if (ext == ".off") return validateOff(path, bytes, maxTriangles);
  throw Error(path + ": unsupported mesh format '" + ext + "' (expected .obj, .ply or .off)");
}

}  // namespace btf
