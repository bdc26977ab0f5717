// What each panel keeps between frames (one struct per panel), apart from the App that owns
// them: a panel is handed its own state and the few shared things it reads (panels.h).
#pragma once
#include <btf/compress/compress.h>
#include <btf/render/renderer.h>

#include <array>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "gl/gl.h"
#include "preview.h"

namespace btf::ui {

// --- per-panel state -------------------------------------------------------------------------

struct PreviewState {
  double thetaV = 0, phiV = 0, thetaL = 30, phiL = 0;  // degrees
  int size = 64;
  int texelU = -1, texelV = -1;  // picked texel (-1: centre)
  float exposure = 1;
  bool logScale = false;
  bool tileAverage = true;  // BRDF hemisphere: tile average (else the picked texel)
  uint64_t requestedRevision = ~0ull, generation = 0;
  bool dirty = true;  // a new request is due
  // The last request computed the BRDF slice and the texel matrix: only while the BRDF panel,
  // which alone shows them, is open (they cost more than the image: one texel's n × n pairs).
  bool requestedAnalysis = false;
  std::chrono::steady_clock::time_point requestTime;
  double firstImageSeconds = -1;  // latency of the last request's first image
  PreviewResult result;
  uint64_t stamp = 0, imageStamp = ~0ull, brdfStamp = ~0ull;  // results polled / uploaded
  gl::Texture image, hemisphere, matrix;
};

struct InspectorState {
  std::string compressed, reference;  // .cbtf and the raw store it came from
  std::shared_ptr<CompressedBtf> cbtf;
  // Shared: a running comparison keeps the decoders it reads even if another file is opened.
  std::shared_ptr<const Decoder> decoder, refDecoder;
  std::string header;  // codec, ratio, components (one paragraph)
  double ratio = 0;
  bool haveReport = false;
  ErrorReport report;
  int comparing = 0;  // job id of a running comparison
  int view = 0, light = 0;
  gl::Texture texelMap, dirMap, original, reconstructed, difference;
  bool texturesDirty = true;
  struct Row {
    std::string codec;
    double ratio, rmse, relRmse, psnr;
  };
  std::vector<Row> codecs;  // one row per compared file
};

struct ObjectState {
  std::string shape = "sphere";  // an object of btf/render/objects.h
  std::string loadedShape;
  float radius = 1;  // the loaded object's bounding radius
  gl::Mesh mesh;
  float yaw = 0.6f, pitch = 0.5f, distance = 3.2f;
  float lightTheta = 40, lightPhi = 30;  // degrees, in the camera's frame
  float exposure = 1.5f, tiling = 2;
  int toneMap = 1;
  bool bilinear = true;
  // Texel levels of a --mip file (docs/mip.md): chosen per pixel from the uv derivatives.
  bool mip = true, showLevel = false;
  gl::Framebuffer fb;
  gl::Program program;
  std::string programError;
  // The tensor decoder's tables on the GPU: "projected_cores" (G per cluster, view and light),
  // "texel_matrices" (M per texel) or "coefficients" (neither fit).
  std::string tensorTables;
  // The most floats the tensor decoder's derived tables may take on the GPU (64 MiB); the
  // script's {"open_compressed": …, "gpu_table_mib": N} sets it (docs/studio.md).
  uint64_t gpuTableFloats = uint64_t(16) << 20;
  std::vector<std::unique_ptr<gl::TextureBuffer>> buffers;  // bound arrays of the decoder
  std::string bound;                                        // path of the bound file
  double frameMs = 0;  // GPU-inclusive time of the last object pass (rendered on change only)
  float renderScale = 0.5f;
  std::string renderedKey;
  int band = -1;     // the next row to render (GL's, from the bottom); -1 when the pass is done
  int bands = 0;     // bands rendered in this pass
  int bandRows = 8;  // rows of the next band (from the cost per row of the last band)
  // Milliseconds of decoding a band aims at: 10 keeps the UI's frame rate; a script run (which
  // waits for the pass, nobody interacting) takes bands of 250 ms, the same pixels in fewer
  // frames (a frame of the UI costs ~25 ms on llvmpipe: 148 bands of a 3.2 s pass added 3.7 s).
  double bandMs = 10;
  double rowMs[2] = {0, 0};  // per view (flat, mapped): the last band's time per row
  double passMs = 0;
  // The GPU view: 0 flat (the BTF looked up on the base surface), 1 mapped (the shell march of
  // shaders/btf_shell.glsl: silhouettes through the raw store's visibility map).
  int view = 0;
  gl::Program mappedProgram;
  std::string shellKey, shellError;  // what the shell tables were built for; why they could not be
  ShellGpuTables shell;              // offsets and counts (the data lives in shellBuf)
  gl::TextureBuffer shellBuf, vmfBuf;
  bool shellHasVmf = false;
  int vmfDirZ = 0;  // offset of the directions' z in vmfBuf
  // The CPU renderer (btfsim render, docs/render.md) on the same view, as a background job:
  // exact | mapped | flat side by side (or one mode), its image and its report's summary.
  int cpuMode = 0;  // all, exact, mapped, flat
  int cpuSpp = 4;
  float reliefScale = 1;
  std::string cpuImagePath, cpuText;
  bool cpuDirty = false;
  gl::Texture cpuImage;
};

struct TileViewState {
  float yaw = 0.8f, pitch = 0.9f, distance = 3.5f;
  int selectedPart = -1;
  uint64_t builtRevision = ~0ull;
  std::string drawnKey;  // what the framebuffer shows (redrawn when it changes)
  int draws = 0;         // times it was drawn (the session report's "tile_view_draws")
  std::string error;
  gl::Mesh mesh, outline, lightLine;
  gl::Program program, lines;
  gl::Framebuffer fb, pick;
  float Lx = 1, Ly = 1, zmin = 0, zmax = 0;
  std::vector<std::array<float, 3>> partColours;
};

struct StudyState {
  std::string dir;  // folder of study.csv
  struct Point {
    std::string label;
    double seconds, error;
    bool pareto;
  };
  std::vector<Point> points;
  std::string chosen;  // label of the configuration matching the scene's settings
  std::string error;
};

}  // namespace btf::ui
