// The live previews' background worker: for the current scene and (view, light) pair it renders
// the texel image progressively (a quarter-resolution direct-light image first, then full
// resolution, then every effect of the plan), the tile-averaged BRDF over views for the light
// (hemisphere grid plus in-plane and cross-plane curves) and one texel's lights × views matrix.
// Every request supersedes the previous one: its stages are cancelled and restarted.
#pragma once
#include <btf/core/math.h>
#include <btf/core/parallel.h>

#include <array>
#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace btf::ui {

struct PreviewRequest {
  std::string sceneJson, source;
  std::filesystem::path baseDir;
  double thetaV = 0, phiV = 0, thetaL = 30, phiL = 0;  // degrees
  int size = 64;                                       // texels per side of the image
  int texelU = -1, texelV = -1;                        // texel of the matrix; -1: the centre
  int brdfGrid = 25;                                   // hemisphere pixels per side
  int brdfSamples = 16;                                // tile samples per axis (btfsim brdf --spp)
  bool brdf = true, matrix = true;
};

struct PreviewResult {
  uint64_t generation = 0;
  std::string error;  // scene or engine error (the other fields are then empty)
  // Texel image (row-major, RGB aBRDF in 1/sr), the stage that produced it and when.
  int nu = 0, nv = 0;
  std::vector<float> image;
  std::string stage;
  double imageSeconds = 0;  // from the request to this image
  bool imageFinal = false;
  std::string plan;  // the effect plan, one line per effect
  // Tile-averaged aBRDF over views for the light: brdfGrid² pixels (orthographic hemisphere,
  // x right, y up), the pairs evaluated (degrees, for btfsim brdf) and their values.
  int brdfGrid = 0, brdfSamples = 0;
  std::vector<std::array<double, 4>> brdfPairs;
  std::vector<int> brdfPixel;  // pixel of each pair
  std::vector<Rgb> brdfValues;
  std::vector<double> curveTheta;  // signed θ in degrees, −89..89
  std::vector<Rgb> inPlane, crossPlane;
  // One texel's views × lights matrix on the preview's direction set.
  int texelU = 0, texelV = 0;
  std::string matrixSet;
  std::vector<std::array<double, 2>> matrixDirsDeg;
  std::vector<float> matrix;  // n × n × 3, rows = views
  bool done = false;          // every stage finished
};

class PreviewWorker {
 public:
  PreviewWorker();
  ~PreviewWorker();
  /// Starts a new generation (cancels the running one); returns its number.
  uint64_t request(const PreviewRequest& r);
  /// Copies the latest result if it changed since the last call.
  bool poll(PreviewResult* out);
  /// True while the current generation still has stages to run.
  bool working() const;

 private:
  void loop();
  void runGeneration(const PreviewRequest& r, uint64_t gen, const CancelToken& cancel);
  void publish(const std::function<void(PreviewResult&)>& f, uint64_t gen);
  mutable std::mutex m_mutex;
  std::condition_variable m_cv;
  PreviewRequest m_req;
  uint64_t m_gen = 0, m_doneGen = 0, m_seen = 0;
  bool m_has = false, m_stop = false, m_changed = false;
  std::shared_ptr<CancelToken> m_cancel;
  PreviewResult m_result;
  std::thread m_thread;
};

/// Signed-θ curve sample: θ ≥ 0 along azimuth φ, θ < 0 along φ + 180°.
std::array<double, 2> curveDirection(double signedTheta, double phi);

}  // namespace btf::ui
