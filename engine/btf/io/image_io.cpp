// Image files: the checks before a reader sees a byte (extension, signature, EXR header, pixel
// budget), the sRGB encoding, atomic writes; OpenImageIO itself is reached through the module
// of btf/io/oiio_module.h, loaded on the first image read or write.
#include <btf/core/error.h>
#include <btf/core/input_file.h>
#include <btf/io/exr_check.h>
#include <btf/io/image_io.h>
#include <btf/io/oiio_module.h>
#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace btf {

namespace {

/// The OpenImageIO module's entry points, resolved once per process.
struct OiioModule {
  BtfOiioWriteFn write = nullptr;
  BtfOiioOpenFn open = nullptr;
  BtfOiioReadFn read = nullptr;
  BtfOiioCloseFn close = nullptr;
  std::string error;  ///< why it could not be loaded (then every entry is null)
};

void oiioProbe() {}  // an address inside this object, for dladdr

/// Where libbtf_oiio.so is looked for: $BTF_OIIO_MODULE alone when set; otherwise beside the
/// object that holds the engine (the Python package's _core.so), beside the executable, and the
/// build tree's own copy.
std::vector<std::string> oiioModuleCandidates() {
  if (const char* e = std::getenv("BTF_OIIO_MODULE"); e && *e) return {e};
  std::vector<std::string> out;
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&oiioProbe), &info) && info.dli_fname && *info.dli_fname)
    out.push_back((std::filesystem::path(info.dli_fname).parent_path() / "libbtf_oiio.so").string());
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) out.push_back((exe.parent_path() / "libbtf_oiio.so").string());
#ifdef BTF_OIIO_MODULE_PATH
  out.push_back(BTF_OIIO_MODULE_PATH);
#endif
  return out;
}

const OiioModule& oiio() {
  static const OiioModule m = [] {
    OiioModule r;
    std::string tried;
    auto refuse = [&](const std::string& path, const std::string& why) {
      tried += (tried.empty() ? "" : ", ") + path + " (" + why + ")";
    };
    for (const std::string& path : oiioModuleCandidates()) {
      if (path.empty()) continue;
      if (!std::filesystem::exists(path)) {
        refuse(path, "missing");
        continue;
      }
      void* h = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!h) {
        const char* why = ::dlerror();
        refuse(path, why ? why : "dlopen failed");
        continue;
      }
      auto abi = reinterpret_cast<BtfOiioAbiFn>(::dlsym(h, "btf_oiio_abi"));
      r.write = reinterpret_cast<BtfOiioWriteFn>(::dlsym(h, "btf_oiio_write"));
      r.open = reinterpret_cast<BtfOiioOpenFn>(::dlsym(h, "btf_oiio_open"));
      r.read = reinterpret_cast<BtfOiioReadFn>(::dlsym(h, "btf_oiio_read"));
      r.close = reinterpret_cast<BtfOiioCloseFn>(::dlsym(h, "btf_oiio_close"));
      if (abi && abi() == BTF_OIIO_ABI && r.write && r.open && r.read && r.close) return r;
      r = OiioModule{};
      refuse(path, "another build: interface " +
                       (abi ? std::to_string(abi()) : std::string("unknown")) + ", expected " +
                       std::to_string(BTF_OIIO_ABI));
      ::dlclose(h);
    }
    r.error = "image I/O: cannot load the OpenImageIO module libbtf_oiio.so (tried " +
              (tried.empty() ? std::string("nothing") : tried) +
              "); set BTF_OIIO_MODULE to its path";
    return r;
  }();
  if (!m.write) throw Error(m.error);
  return m;
}

}  // namespace

float linearToSrgb(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

void writeRgbImage(const std::string& path, int w, int h, const std::vector<float>& rgb,
                   float scale, bool flipY, const ImageMetadata& metadata) {
  writeRgbaImage(path, w, h, rgb, nullptr, scale, flipY, metadata);
}

void writeRgbaImage(const std::string& path, int w, int h, const std::vector<float>& rgb,
                    const std::vector<float>* alpha, float scale, bool flipY,
                    const ImageMetadata& metadata) {
  BTF_CHECK(rgb.size() == size_t(w) * h * 3);
  BTF_CHECK(!alpha || alpha->size() == size_t(w) * h);
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".exr" && ext != ".png" && ext != ".jpg" && ext != ".jpeg")
    throw Error(path + ": unsupported image type '" + ext +
                "' (expected .exr, linear float, or .png / .jpg, sRGB)");
  const bool hdr = ext == ".exr";
  const int nc = hdr && alpha ? 4 : 3;  // PNG: the colour over black, no alpha
  // Images are stored bottom row first in memory (v up); files are top row first.
  std::vector<float> px(size_t(w) * size_t(h) * size_t(nc));
  for (int j = 0; j < h; ++j) {
    const int src = flipY ? h - 1 - j : j;
    for (int i = 0; i < w; ++i) {
      const size_t sp = size_t(src) * size_t(w) + size_t(i), dp = size_t(j) * size_t(w) + size_t(i);
      for (int c = 0; c < 3; ++c) {
        float v = rgb[sp * 3 + size_t(c)];
        if (!std::isfinite(v)) v = 0;
        px[dp * size_t(nc) + size_t(c)] = hdr ? v : linearToSrgb(v * scale);
      }
      if (nc == 4) {
        const float a = (*alpha)[sp];
        px[dp * 4 + 3] = std::isfinite(a) ? std::clamp(a, 0.f, 1.f) : 0.f;
      }
    }
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  const std::string tmp = path + ".tmp" + ext;  // keep the extension so OIIO picks the format
  std::vector<const char*> keys, values;
  if (hdr)
    for (const auto& [k, v] : metadata) keys.push_back(k.c_str()), values.push_back(v.c_str());
  const BtfOiioWrite req{path.c_str(), tmp.c_str(), w,  h, nc, hdr ? 1 : 0, ext != ".png" ? 1 : 0,
                         keys.data(),  values.data(), int(keys.size()), px.data()};
  char err[1024] = "";
  if (oiio().write(&req, err, sizeof err) != 0) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw Error(path + ": " + err);
  }
  std::filesystem::rename(tmp, path);
}

namespace {

/// Points fd 2 at a temporary file for its lifetime (one at a time in the process).
class StderrCapture {
 public:
  StderrCapture() : m_lock(mutex()) {
    std::fflush(stderr);
    m_saved = ::dup(2);
    m_tmp = std::tmpfile();
    if (m_saved >= 0 && m_tmp) ::dup2(::fileno(m_tmp), 2);
  }
  ~StderrCapture() {
    std::fflush(stderr);
    if (m_saved >= 0) {
      ::dup2(m_saved, 2);
      ::close(m_saved);
    }
    if (m_tmp) std::fclose(m_tmp);
  }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> m_lock;
  int m_saved = -1;
  std::FILE* m_tmp = nullptr;
};

}  // namespace

std::vector<float> readImageChecked(const std::string& path, uint64_t maxPixels,
                                    const std::string& what, int* width, int* height, int* channels,
                                    int decode) {
  // Compressed formats hold many pixels per byte, so the file's size bounds nothing: the
  // header's dimensions are checked against maxPixels before any pixel is decoded.
  const uint64_t size = checkInputFile(path, what);
  // The format is the extension's, and the file's first bytes must be that format's signature:
  // OpenImageIO would otherwise hand a file its plugin refuses to every other format's reader.
  struct Format {
    const char* ext;
    const char* plugin;
    const char* name;
  };
  static const Format kFormats[] = {{".png", "png", "PNG"},          {".exr", "openexr", "OpenEXR"},
                                    {".hdr", "hdr", "Radiance HDR"}, {".pgm", "pnm", "PNM"},
                                    {".ppm", "pnm", "PNM"},          {".pnm", "pnm", "PNM"},
                                    {".tif", "tiff", "TIFF"},        {".tiff", "tiff", "TIFF"},
                                    {".jpg", "jpeg", "JPEG"},        {".jpeg", "jpeg", "JPEG"}};
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  const Format* fmt = nullptr;
  for (const Format& f : kFormats)
    if (ext == f.ext) fmt = &f;
  if (!fmt)
    throw Error(path + ": unsupported " + what + " type '" + ext +
                "' (PNG, OpenEXR, Radiance HDR, PNM, TIFF or JPEG)");
  std::string head;
  {
    std::ifstream f(path, std::ios::binary);
    head.assign(size_t(std::min<uint64_t>(size, uint64_t(16) << 20)), '\0');
    f.read(head.data(), std::streamsize(head.size()));
    head.resize(size_t(f.gcount()));
  }
  const std::string_view plugin = fmt->plugin;
  const bool signed_ =
      (plugin == "png" && head.rfind("\x89PNG\r\n\x1a\n", 0) == 0) ||
      (plugin == "openexr" && head.rfind("\x76\x2f\x31\x01", 0) == 0) ||
      (plugin == "hdr" && head.rfind("#?", 0) == 0) ||
      (plugin == "pnm" && head.size() >= 2 && head[0] == 'P' &&
       std::string_view("123456fF").find(head[1]) != std::string_view::npos) ||
      (plugin == "tiff" && (head.rfind("II*", 0) == 0 || head.rfind("MM", 0) == 0)) ||
      (plugin == "jpeg" && head.rfind("\xff\xd8\xff", 0) == 0);
  if (!signed_)
    throw Error(path + ": content does not match the " + ext + " extension (no " + fmt->name +
                " signature in its first bytes)");
  // OpenEXR sizes allocations from its header before reading a pixel: walked first.
  if (plugin == "openexr") checkExrHeader(path, head, maxPixels);
    // libpng and libjpeg print their own complaints on stderr before OpenImageIO reports them:
    // that text is kept off the terminal while the image is read (the error we throw carries
    // OpenImageIO's message), so a damaged image is one line like every other error.
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION  // the fuzzer's own reports must reach stderr
  StderrCapture quiet;
#endif
  // The plugin by its name, opened alone (no other reader is tried).
  const OiioModule& io = oiio();
  BtfOiioSpec spec{};
  char err[1024] = "";
  struct Handle {
    const OiioModule& io;
    void* h;
    ~Handle() {
      if (h) io.close(h);
    }
  } in{io, io.open(std::string(plugin).c_str(), path.c_str(), &spec, err, sizeof err)};
  if (!in.h) throw Error(path + ": cannot read " + what + " (" + oneLine(err) + ")");
  const int64_t w = spec.width, h = spec.height, ch = spec.channels;
  if (w <= 0 || h <= 0 || ch <= 0) throw Error(path + ": " + what + " is empty");
  if (spec.depth > 1) throw Error(path + ": " + what + " is a volume (depth > 1)");
  if (w > 65536 || h > 65536 || uint64_t(w) * uint64_t(h) > maxPixels)
    throw Error(path + ": " + what + " of " + std::to_string(w) + " × " + std::to_string(h) +
                " pixels is larger than the " + std::to_string(maxPixels) +
                " pixels the memory budget allows");
  if (ch > 64) throw Error(path + ": " + what + " has " + std::to_string(ch) + " channels");
  const int n = decode > 0 ? int(std::min<int64_t>(decode, ch)) : int(ch);
  std::vector<float> all(size_t(w) * size_t(h) * size_t(n));
  if (io.read(in.h, n, all.data(), err, sizeof err) != 0)
    throw Error(path + ": cannot read " + what + " (" + oneLine(err) + ")");
  *width = int(w);
  *height = int(h);
  *channels = n;
  return all;
}

std::vector<float> readRgbImage(const std::string& path, int* w, int* h,
                                std::vector<float>* alpha) {
  int nc = 0;
  const std::vector<float> all =
      readImageChecked(path, uint64_t(1) << 26, "image", w, h, &nc, alpha ? 4 : 3);
  std::vector<float> rgb(size_t(*w) * size_t(*h) * 3);
  for (size_t p = 0; p < size_t(*w) * size_t(*h); ++p)
    for (int c = 0; c < 3; ++c)
      rgb[p * 3 + size_t(c)] = all[p * size_t(nc) + size_t(std::min(c, nc - 1))];
  if (alpha) {
    alpha->assign(size_t(*w) * size_t(*h), 1.0f);
    if (nc == 4 || nc == 2)  // RGBA, or grey + alpha
      for (size_t p = 0; p < alpha->size(); ++p) (*alpha)[p] = all[p * size_t(nc) + size_t(nc - 1)];
  }
  return rgb;
}

}  // namespace btf
