#include <btf/core/parallel.h>
#include <pmmintrin.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
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

ThreadLimit::ThreadLimit(int threads) {
  if (threads > 0)
    m_control =
        new tbb::global_control(tbb::global_control::max_allowed_parallelism, size_t(threads));
}
ThreadLimit::~ThreadLimit() {
  delete static_cast<tbb::global_control*>(m_control);
}
int ThreadLimit::current() {
  return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
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
