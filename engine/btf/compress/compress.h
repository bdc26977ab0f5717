// Compression jobs and error metrics (docs/compression.md): compress a stored raw BTF chunk by
// chunk (memory bounded by the encoder, not the data), and compare two BTFs of the same geometry
// (raw or compressed) with ratio, RMSE, relative RMSE, PSNR and per-texel / per-direction maps.
#pragma once
#include <btf/compress/codec.h>
#include <btf/core/comm.h>

#include <string>
#include <vector>

namespace btf {

struct CompressReport {
  double seconds = 0, trainSeconds = 0, encodeSeconds = 0, finishSeconds = 0;
  uint64_t peakRssBytes = 0, fileBytes = 0;
  double ratio = 0;
  int64_t texels = 0;
  // A cluster job: ranks, this rank's encoded texels and its communicated bytes.
  int ranks = 1;
  int64_t texelsEncoded = 0;
  double texelBytes = 0;  // raw bytes of one texel
  uint64_t commBytes = 0;
};

/// Fills the report's totals from the finished file (time since `start` in seconds, peak
/// memory, bytes, ratio).
void finishReport(CompressReport* r, const CompressedBtf& out, double seconds);

/// Encodes every texel of a raw store (training texels first). Progress on stderr when asked.
/// With a distributed `comm` (docs/cluster.md) every rank reads and trains on the training
/// texels, encodes its share of the chunks (contiguous), and the encoder finishes over the ranks
/// (Encoder::finishOn): the same bytes as one process. Ranks other than 0 return an empty
/// CompressedBtf.
CompressedBtf compressStore(const std::string& inPath, const CodecSettings& s, bool progress,
                            const CancelToken* cancel, CompressReport* report,
                            Comm* comm = nullptr);

struct ErrorReport {
  int nu = 0, nv = 0, nDirs = 0;
  double rmse = 0, refRms = 0, relRmse = 0, psnr = 0, peak = 0, maxAbs = 0;
  int64_t values = 0;
  std::vector<float> texelRmse;  // nu × nv, row-major from (u, v) = (0, 0)
  std::vector<float> dirRmse;    // nViews × nLights
  struct Worst {
    int64_t index = 0;  // texel, or view · nL + light
    double rmse = 0;
  };
  std::vector<Worst> worstTexels, worstDirections;
};

/// Both BTFs must share texels and directions (btf::Error otherwise).
/// With a distributed `comm` each rank compares a contiguous share of the texels and every rank
/// gets the whole report.
ErrorReport compareBtfs(const Decoder& ref, const Decoder& test, bool progress, int worst = 10,
                        const CancelToken* cancel = nullptr, Comm* comm = nullptr);
/// texel_rmse.{exr,png} and direction_rmse.{exr,png} in dir (PNG scaled to its maximum).
void writeErrorMaps(const ErrorReport& r, const std::string& dir);
std::string errorReportJson(const ErrorReport& r);

}  // namespace btf
