#define GL_GLEXT_PROTOTYPES 1
#include "gl.h"

#include <GL/gl.h>
#include <GL/glext.h>
#include <btf/compress/linalg.h>
#include <btf/core/error.h>

#include <cstring>

namespace btf::ui::gl {

std::string contextDescription() {
  const char* v = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  const char* r = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  if (major * 10 + minor < 33)
    throw Error(std::string("OpenGL 3.3 core is needed, the context gives ") + (v ? v : "?"));
  return std::string(r ? r : "?") + ", OpenGL " + (v ? v : "?");
}

Texture::~Texture() {
  if (m_id) glDeleteTextures(1, &m_id);
}

void Texture::setRgba8(int w, int h, const uint8_t* rgba, bool nearest) {
  if (!m_id) glGenTextures(1, &m_id);
  glBindTexture(GL_TEXTURE_2D, m_id);
  const GLint f = nearest ? GL_NEAREST : GL_LINEAR;
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, f);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, f);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (w == m_w && h == m_h)
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
  else
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
  m_w = w;
  m_h = h;
}

TextureBuffer::~TextureBuffer() {
  if (m_tex) glDeleteTextures(1, &m_tex);
  if (m_buf) glDeleteBuffers(1, &m_buf);
}

void TextureBuffer::set(const float* data, size_t count, bool half) {
  if (!m_buf) glGenBuffers(1, &m_buf);
  if (!m_tex) glGenTextures(1, &m_tex);
  glBindBuffer(GL_TEXTURE_BUFFER, m_buf);
  if (half) {
    // The file's f16 arrays are decoded to float on load; re-encoding gives the stored bits.
    std::vector<uint16_t> h(count);
    for (size_t i = 0; i < count; ++i) h[i] = la::floatToHalf(data[i]);
    glBufferData(GL_TEXTURE_BUFFER, GLsizeiptr(std::max<size_t>(1, count) * 2), h.data(),
                 GL_STATIC_DRAW);
  } else {
    glBufferData(GL_TEXTURE_BUFFER, GLsizeiptr(std::max<size_t>(1, count) * 4), data,
                 GL_STATIC_DRAW);
  }
  glBindTexture(GL_TEXTURE_BUFFER, m_tex);
  glTexBuffer(GL_TEXTURE_BUFFER, half ? GL_R16F : GL_R32F, m_buf);
  glBindBuffer(GL_TEXTURE_BUFFER, 0);
  m_count = count;
}

Program::~Program() {
  if (m_id) glDeleteProgram(m_id);
}

namespace {
GLuint compile(GLenum type, const std::string& src, const std::string& name) {
  GLuint s = glCreateShader(type);
  const char* p = src.c_str();
  glShaderSource(s, 1, &p, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096] = {0};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw Error(name + (type == GL_VERTEX_SHADER ? " (vertex)" : " (fragment)") +
                ": GLSL compile error:\n" + log);
  }
  return s;
}
}  // namespace

void Program::build(const std::string& name, const std::string& vertex,
                    const std::string& fragment) {
  GLuint vs = compile(GL_VERTEX_SHADER, vertex, name);
  GLuint fs;
  try {
    fs = compile(GL_FRAGMENT_SHADER, fragment, name);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  glBindAttribLocation(p, 0, "a_position");
  glBindAttribLocation(p, 1, "a_normal");
  glBindAttribLocation(p, 2, "a_uv");
  glLinkProgram(p);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096] = {0};
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    glDeleteProgram(p);
    throw Error(name + ": GLSL link error:\n" + log);
  }
  if (m_id) glDeleteProgram(m_id);
  m_id = p;
}

void Program::use() const {
  glUseProgram(m_id);
}
int Program::uniform(const char* name) const {
  return glGetUniformLocation(m_id, name);
}
void Program::set(const char* name, int v) const {
  glUniform1i(uniform(name), v);
}
void Program::set(const char* name, float v) const {
  glUniform1f(uniform(name), v);
}
void Program::set(const char* name, float x, float y) const {
  glUniform2f(uniform(name), x, y);
}
void Program::set(const char* name, float x, float y, float z) const {
  glUniform3f(uniform(name), x, y, z);
}
void Program::setMat4(const char* name, const float* m) const {
  glUniformMatrix4fv(uniform(name), 1, GL_FALSE, m);
}
void Program::setInts(const char* name, const int* v, int n) const {
  glUniform1iv(uniform(name), n, v);
}
void Program::setFloats(const char* name, const float* v, int n) const {
  glUniform1fv(uniform(name), n, v);
}
void Program::setVec3s(const char* name, const float* v, int n) const {
  glUniform3fv(uniform(name), n, v);
}
void Program::bindBuffer(const char* name, const TextureBuffer& b, int unit) const {
  glActiveTexture(GLenum(GL_TEXTURE0 + unit));
  glBindTexture(GL_TEXTURE_BUFFER, b.texture());
  glUniform1i(uniform(name), unit);
  glActiveTexture(GL_TEXTURE0);
}

Mesh::~Mesh() {
  if (m_ibo) glDeleteBuffers(1, &m_ibo);
  if (m_vbo) glDeleteBuffers(1, &m_vbo);
  if (m_vao) glDeleteVertexArrays(1, &m_vao);
}

void Mesh::set(const std::vector<Vertex>& v, const std::vector<uint32_t>& indices, bool lines) {
  if (!m_vao) {
    glGenVertexArrays(1, &m_vao);
    glGenBuffers(1, &m_vbo);
    glGenBuffers(1, &m_ibo);
  }
  glBindVertexArray(m_vao);
  glBindBuffer(GL_ARRAY_BUFFER, m_vbo);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(v.size() * sizeof(Vertex)), v.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m_ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(indices.size() * 4), indices.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                        reinterpret_cast<void*>(offsetof(Vertex, n)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                        reinterpret_cast<void*>(offsetof(Vertex, uv)));
  glBindVertexArray(0);
  m_count = int(indices.size());
  m_lines = lines;
}

void Mesh::draw() const {
  if (!m_count) return;
  glBindVertexArray(m_vao);
  glDrawElements(m_lines ? GL_LINES : GL_TRIANGLES, m_count, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

void Mesh::drawInstanced(int instances) const {
  if (!m_count) return;
  glBindVertexArray(m_vao);
  glDrawElementsInstanced(m_lines ? GL_LINES : GL_TRIANGLES, m_count, GL_UNSIGNED_INT, nullptr,
                          instances);
  glBindVertexArray(0);
}

std::array<uint8_t, 4> Framebuffer::readPixel(int x, int y) const {
  std::array<uint8_t, 4> px{0, 0, 0, 0};
  if (x < 0 || y < 0 || x >= m_w || y >= m_h) return px;
  glBindFramebuffer(GL_FRAMEBUFFER, m_fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(x, y, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return px;
}

Framebuffer::~Framebuffer() {
  if (m_fbo) glDeleteFramebuffers(1, &m_fbo);
  if (m_colour) glDeleteTextures(1, &m_colour);
  if (m_depth) glDeleteRenderbuffers(1, &m_depth);
}

void Framebuffer::resize(int w, int h, bool floating) {
  w = std::max(1, w);
  h = std::max(1, h);
  if (m_fbo && w == m_w && h == m_h && floating == m_float) return;
  if (!m_fbo) {
    glGenFramebuffers(1, &m_fbo);
    glGenTextures(1, &m_colour);
    glGenRenderbuffers(1, &m_depth);
  }
  glBindTexture(GL_TEXTURE_2D, m_colour);
  glTexImage2D(GL_TEXTURE_2D, 0, floating ? GL_RGBA32F : GL_RGBA8, w, h, 0, GL_RGBA,
               floating ? GL_FLOAT : GL_UNSIGNED_BYTE, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glBindRenderbuffer(GL_RENDERBUFFER, m_depth);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
  glBindFramebuffer(GL_FRAMEBUFFER, m_fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, m_colour, 0);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, m_depth);
  const GLenum st = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (st != GL_FRAMEBUFFER_COMPLETE) throw Error("framebuffer incomplete");
  m_w = w;
  m_h = h;
  m_float = floating;
}

void Framebuffer::begin(float r, float g, float b, float a) const {
  glBindFramebuffer(GL_FRAMEBUFFER, m_fbo);
  glViewport(0, 0, m_w, m_h);
  glClearColor(r, g, b, a);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

void Framebuffer::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, m_fbo);
  glViewport(0, 0, m_w, m_h);
}

void scissor(int x, int y, int w, int h) {
  glEnable(GL_SCISSOR_TEST);
  glScissor(x, y, w, h);
}

void noScissor() {
  glDisable(GL_SCISSOR_TEST);
}

void Framebuffer::end(int windowW, int windowH) {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, windowW, windowH);
}

std::vector<float> Framebuffer::readFloat() const {
  std::vector<float> px(size_t(m_w) * m_h * 4);
  glBindFramebuffer(GL_FRAMEBUFFER, m_fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, m_w, m_h, GL_RGBA, GL_FLOAT, px.data());
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return px;
}

std::vector<uint8_t> readBackBuffer(int w, int h) {
  std::vector<uint8_t> px(size_t(w) * h * 3), out(px.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, px.data());
  for (int y = 0; y < h; ++y)
    std::memcpy(&out[size_t(y) * w * 3], &px[size_t(h - 1 - y) * w * 3], size_t(w) * 3);
  return out;
}

void drawFullscreen() {
  static GLuint vao = 0;  // core profile needs a bound VAO even without attributes
  if (!vao) glGenVertexArrays(1, &vao);
  glDisable(GL_DEPTH_TEST);
  glBindVertexArray(vao);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
}

void finish() {
  glFinish();
}

void begin3d() {
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_BLEND);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_CULL_FACE);
}

void end3d() {
  glDisable(GL_DEPTH_TEST);
}

}  // namespace btf::ui::gl
