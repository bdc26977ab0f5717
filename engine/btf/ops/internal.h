// Shared by the use-case files of btf/ops (not part of the engine's public surface).
#pragma once
#include <btf/core/format.h>
#include <btf/ops/ops.h>
#include <btf/scene/scene.h>

#include <cstdarg>
#include <string>

namespace btf {
struct CompressedBtf;
struct PyramidReport;
}  // namespace btf

namespace btf::ops::detail {

using json = nlohmann::ordered_json;

using btf::format;  // btf/core/format.h

/// What every use case gets: the request, the context (progress already folded with --quiet),
/// the note sink and the report to fill.
struct Call {
  const Request& r;
  const RunContext& ctx;
  const NoteSink& note;
  Report& rep;
  const Scene* preloaded = nullptr;
  /// The request's scene: the caller's document when given, else the file.
  Scene scene() const;
  bool progress() const { return ctx.progress && !r.b("quiet"); }
  void notice(std::string s) const {
    while (!s.empty() && s.back() == '\n') s.pop_back();
    rep.notes.push_back(s);
    if (note) note(s);
  }
  void warn(const std::string& s) const {
    rep.warnings.push_back(s);
    if (note) note("btfsim: warning: " + s);
  }
};

void simulate(const Call& c);
void plan(const Call& c);
void bench(const Call& c);
void brdf(const Call& c);
void compress(const Call& c);
void compare(const Call& c);
void exportBtf(const Call& c);
void info(const Call& c);
void slice(const Call& c);
void render(const Call& c);
void study(const Call& c);

/// A cluster job's figures (docs/cluster.md): per rank, texels computed or encoded and bytes
/// communicated, against that rank's bytes of aBRDF. Every rank calls it (a collective).
/// `seconds`: the rank's own work (its chunks), to show the balance; `lightsSolved` and
/// `giShareBytes`: its part of the network's light solve and the bytes of sharing it and the
/// reciprocal gather's tile sums (a simulation with inter-reflection).
ClusterFigures clusterFigures(Comm& comm, double texels, double texelBytes, uint64_t commBytes,
                              double seconds, int lightsSolved = 0, uint64_t giShareBytes = 0);
std::string clusterText(const ClusterFigures& cluster);

// Shared by the compressing use cases (compress, simulate --compress).
/// Warns when the ratio asked could not be spent or the codec's own stage exceeds the target
/// (also the studio's warning).
void warnTarget(const Call& c, const CompressedBtf& b);
std::string compressedText(const CompressedBtf& b, double seconds, uint64_t rss);
/// A pyramid's levels and their errors: the report's lines, and the levels' figures.
std::string levelsReport(const PyramidReport& rep, std::vector<LevelFigures>* levels);
/// The codec's params and stats (parsed), sizes and ratio of a compressed file.
CodecFigures codecFigures(const CompressedBtf& b, double rawBytes, uint64_t compressedBytes,
                          double ratio, uint64_t peakMemoryBytes);

/// "1,2,3" → items; throws naming the option when empty.
std::vector<std::string> splitList(const std::string& s, const std::string& what);
std::vector<int> intList(const std::string& s, const std::string& what, int lo, int hi);

}  // namespace btf::ops::detail
