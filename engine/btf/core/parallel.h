// Parallel loops over TBB (pbrt's ParallelFor shape), with cancellation checked per chunk.
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>

namespace btf {

/// Cooperative cancellation (Mitsuba's should_stop): long kernels poll it per chunk.
class CancelToken {
 public:
  void cancel() { m_flag.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return m_flag.load(std::memory_order_relaxed); }

 private:
  std::atomic<bool> m_flag{false};
};

/// Runs fn(begin, end) over [0, count) in chunks of about `grain`; stops early when cancelled.
void parallelForChunks(int64_t count, int64_t grain,
                       const std::function<void(int64_t, int64_t)>& fn,
                       const CancelToken* cancel = nullptr);

/// Sets flush-to-zero / denormals-are-zero on every TBB worker (Embree asks for it).
void enableFlushToZeroOnWorkers();

}  // namespace btf
