// One run context for every long operation (docs/architecture.md): a cancel token whose one
// outcome is the Cancelled exception, a per-run thread count through its own tbb::task_arena
// (never process-wide: a studio job never slows the preview worker), the memory budget, and
// whether progress bars are printed. The use cases of btf/ops take one; stages take its parts.
#pragma once
#include <btf/core/comm.h>
#include <btf/core/error.h>
#include <btf/core/parallel.h>

#include <cstdint>
#include <functional>
#include <string>

namespace btf {

/// The one outcome of a cancelled stage, whichever stage it was (estimate, network build,
/// planner, chunks, encoder, export): thrown once the token is set, caught by the front door.
class Cancelled : public Error {
 public:
  explicit Cancelled(const std::string& stage) : Error(stage + " cancelled"), m_stage(stage) {}
  const std::string& stage() const { return m_stage; }

 private:
  std::string m_stage;
};

/// Throws Cancelled(stage) when `cancel` is set.
inline void throwIfCancelled(const CancelToken* cancel, const char* stage) {
  if (cancel && cancel->cancelled()) throw Cancelled(stage);
}

/// Runs fn with at most `threads` worker threads (0 = every core) in an arena of its own: the
/// limit holds for fn and everything it runs in parallel, and for nothing else in the process.
void withThreads(int threads, const std::function<void()>& fn);
/// Worker threads available to parallel loops started from the calling thread's arena.
int currentThreads();

struct RunContext {
  const CancelToken* cancel = nullptr;
  int threads = 0;                            // 0 = every core
  uint64_t memoryBudget = uint64_t(4) << 30;  // refusal above it, with the figures
  bool progress = true;                       // bars on stderr (the studio polls instead)
  bool keepPartial = false;  // on Cancelled, keep OUTPUT.partial for a resume (studio's "stop")
  /// The job's processes (docs/cluster.md): null = this process alone.
  Comm* comm = nullptr;
  Comm& processes() const { return comm ? *comm : localComm(); }
  void check(const char* stage) const { throwIfCancelled(cancel, stage); }
};

}  // namespace btf
