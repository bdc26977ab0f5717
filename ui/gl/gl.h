// The GL seam (Polyscope's render-engine idea): the only code of the studio that calls gl*.
// Panels ask it for textures, meshes, programs, framebuffers and texture buffers; every object
// is RAII and lives on the main thread (the thread that owns the context).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace btf::ui::gl {

/// Loads the GL 3.3 entry points we use (no-op with GL_GLEXT_PROTOTYPES) and checks the
/// context version; throws btf::Error when the context cannot do GL 3.3 core.
std::string contextDescription();

class Texture {
 public:
  Texture() = default;
  ~Texture();
  Texture(const Texture&) = delete;
  Texture& operator=(const Texture&) = delete;
  /// RGBA8 pixels, row 0 at the top (as ImGui shows them). Nearest or linear filtering.
  void setRgba8(int w, int h, const uint8_t* rgba, bool nearest = true);
  unsigned id() const { return m_id; }
  int width() const { return m_w; }
  int height() const { return m_h; }
  /// ImGui's texture handle.
  void* imguiId() const { return reinterpret_cast<void*>(uintptr_t(m_id)); }

 private:
  unsigned m_id = 0;
  int m_w = 0, m_h = 0;
};

/// A float array as a samplerBuffer: R16F when `half` (the data are IEEE half bits) or R32F.
class TextureBuffer {
 public:
  TextureBuffer() = default;
  ~TextureBuffer();
  TextureBuffer(const TextureBuffer&) = delete;
  TextureBuffer& operator=(const TextureBuffer&) = delete;
  void set(const float* data, size_t count, bool half);
  unsigned texture() const { return m_tex; }
  size_t count() const { return m_count; }

 private:
  unsigned m_buf = 0, m_tex = 0;
  size_t m_count = 0;
};

class Program {
 public:
  Program() = default;
  ~Program();
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;
  /// Compiles and links; throws btf::Error with the shader's name and the driver's log.
  void build(const std::string& name, const std::string& vertex, const std::string& fragment);
  bool valid() const { return m_id != 0; }
  void use() const;
  int uniform(const char* name) const;
  void set(const char* name, int v) const;
  void set(const char* name, float v) const;
  void set(const char* name, float x, float y) const;
  void set(const char* name, float x, float y, float z) const;
  void setMat4(const char* name, const float* m) const;  // column-major
  void setInts(const char* name, const int* v, int n) const;
  void setFloats(const char* name, const float* v, int n) const;
  void setVec3s(const char* name, const float* v, int n) const;
  /// Binds a texture buffer to `unit` and the sampler uniform `name` to it.
  void bindBuffer(const char* name, const TextureBuffer& b, int unit) const;

 private:
  unsigned m_id = 0;
};

/// Interleaved vertices: position (3), normal (3), uv (2).
struct Vertex {
  float p[3], n[3], uv[2];
};

class Mesh {
 public:
  Mesh() = default;
  ~Mesh();
  Mesh(const Mesh&) = delete;
  Mesh& operator=(const Mesh&) = delete;
  void set(const std::vector<Vertex>& v, const std::vector<uint32_t>& indices, bool lines = false);
  void draw() const;
  void drawInstanced(int instances) const;
  bool empty() const { return m_count == 0; }

 private:
  unsigned m_vao = 0, m_vbo = 0, m_ibo = 0;
  int m_count = 0;
  bool m_lines = false;
};

/// An off-screen target: colour (RGBA8, or RGBA32F when `floating`) and depth.
class Framebuffer {
 public:
  Framebuffer() = default;
  ~Framebuffer();
  Framebuffer(const Framebuffer&) = delete;
  Framebuffer& operator=(const Framebuffer&) = delete;
  void resize(int w, int h, bool floating = false);
  /// Binds it, sets the viewport and clears to `clear`.
  void begin(float r, float g, float b, float a) const;
  /// Binds it and sets the viewport, keeping its content.
  void bind() const;
  static void end(int windowW, int windowH);
  unsigned colour() const { return m_colour; }
  int width() const { return m_w; }
  int height() const { return m_h; }
  void* imguiId() const { return reinterpret_cast<void*>(uintptr_t(m_colour)); }
  /// RGBA floats, row 0 at the bottom (GL's order).
  std::vector<float> readFloat() const;
  /// One RGBA8 pixel (x, y from the bottom-left); zeros outside.
  std::array<uint8_t, 4> readPixel(int x, int y) const;

 private:
  unsigned m_fbo = 0, m_colour = 0, m_depth = 0;
  int m_w = 0, m_h = 0;
  bool m_float = false;
};

/// The back buffer as RGB8, row 0 at the top (a screenshot).
std::vector<uint8_t> readBackBuffer(int w, int h);

/// Draws the full-screen triangle (fullscreen.vert) with the bound program.
void drawFullscreen();
/// Restricts drawing to a rectangle (pixels from the bottom-left) / lifts it.
void scissor(int x, int y, int w, int h);
void noScissor();
/// Waits for the GL pipeline (timing a pass on llvmpipe).
void finish();

/// Depth test and culling state for 3D passes (restored by end3d).
void begin3d();
void end3d();

}  // namespace btf::ui::gl
