// The live preview as a use case (the studio's preview worker runs it on its own thread; a test
// or the Python package may run it directly): for a scene and one (view, light) pair, the texel
// image progressively (a quarter-resolution direct-light image first, then full resolution, then
// every effect of the plan), the tile-averaged BRDF over views for the light (hemisphere grid
// plus in-plane and cross-plane curves) and one texel's lights × views matrix. Each stage is
// published as soon as it is known; a cancelled token stops between and inside stages.
#pragma once
#include <btf/core/math.h>
#include <btf/core/parallel.h>

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace btf::ops {

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

/// Receives each stage: the function it is given fills the result in place (under the caller's
/// lock; the caller drops stages of a superseded request).
using PreviewPublish = std::function<void(const std::function<void(PreviewResult&)>&)>;

/// Runs every stage of `r`; returns early (nothing more published) once `cancel` is set. Scene
/// and engine errors throw btf::Error; cancellation inside a stage may throw btf::Cancelled.
void runPreview(const PreviewRequest& r, const CancelToken& cancel, const PreviewPublish& publish);

/// Signed-θ curve sample: θ ≥ 0 along azimuth φ, θ < 0 along φ + 180°.
std::array<double, 2> curveDirection(double signedTheta, double phi);

}  // namespace btf::ops
