#include <btf/core/parallel.h>
#include <btf/core/run_context.h>
#include <pmmintrin.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>
#include <xmmintrin.h>

#include <algorithm>
#include <memory>

namespace btf {

void parallelForChunks(int64_t count, int64_t grain,
                       const std::function<void(int64_t, int64_t)>& fn, const CancelToken* cancel) {
  if (count <= 0) return;
  grain = std::max<int64_t>(1, grain);
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, count, grain),
                    [&](const tbb::blocked_range<int64_t>& r) {
                      if (cancel && cancel->cancelled()) return;
                      fn(r.begin(), r.end());
                    });
}

void withThreads(int threads, const std::function<void()>& fn) {
  if (threads < 0)
    throw Error("invalid thread count " + std::to_string(threads) + ": must be >= 0");
  if (threads == 0) {
    fn();
    return;
  }
  tbb::task_arena arena(threads);
  arena.execute(fn);
}

int currentThreads() {
  return tbb::this_task_arena::max_concurrency();
}

namespace {
class FtzObserver : public tbb::task_scheduler_observer {
 public:
  FtzObserver() { observe(true); }
  void on_scheduler_entry(bool) override {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
};
}  // namespace

void enableFlushToZeroOnWorkers() {
  static std::unique_ptr<FtzObserver> observer = std::make_unique<FtzObserver>();
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

}  // namespace btf
