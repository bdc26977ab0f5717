#include <btf/core/parallel.h>
#include <btf/core/run_context.h>
#include <pmmintrin.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>
#include <xmmintrin.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace btf {

#ifdef BTF_TSAN
// ThreadSanitizer builds (make tsan): TBB's scheduler is not instrumented, so the
// happens-before edges of its task spawns and joins are invisible to TSan and every kernel
// would be reported racy (or, with TBB suppressed, none checked). Here the same loops run on
// std::threads with an atomic chunk counter, so TSan sees every edge and checks what our
// kernels share. Same chunks, same results (the kernels are deterministic per chunk).
namespace {
thread_local int t_threads = 0;  // the withThreads limit of this thread's run (0 = every core)

int threadsHere() {
  const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
  return t_threads > 0 ? t_threads : hw;
}
}  // namespace

void parallelForChunks(int64_t count, int64_t grain,
                       const std::function<void(int64_t, int64_t)>& fn, const CancelToken* cancel) {
  if (count <= 0) return;
  grain = std::max<int64_t>(1, grain);
  const int64_t chunks = (count + grain - 1) / grain;
  const int workers = int(std::min<int64_t>(threadsHere(), chunks));
  std::atomic<int64_t> next{0};
  std::exception_ptr error;
  std::mutex errorMutex;
  const int limit = t_threads;
  auto work = [&] {
    t_threads = limit;
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    for (int64_t c; (c = next.fetch_add(1)) < chunks;) {
      if (cancel && cancel->cancelled()) return;
      try {
        fn(c * grain, std::min(count, (c + 1) * grain));
      } catch (...) {
        std::lock_guard lock(errorMutex);
        if (!error) error = std::current_exception();
        next.store(chunks);
      }
    }
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < workers; ++k) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

void withThreads(int threads, const std::function<void()>& fn) {
  if (threads < 0)
    throw Error("invalid thread count " + std::to_string(threads) + ": must be >= 0");
  const int saved = t_threads;
  if (threads > 0) t_threads = threads;
  try {
    fn();
  } catch (...) {
    t_threads = saved;
    throw;
  }
  t_threads = saved;
}

int currentThreads() {
  return threadsHere();
}

void enableFlushToZeroOnWorkers() {
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

#else

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

#endif

}  // namespace btf
