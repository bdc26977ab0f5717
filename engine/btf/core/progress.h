// Progress of a long kernel: workers add to an atomic counter; the reporter prints a bar with
// rate and ETA on stderr (redrawn on a terminal, a line every 10 % otherwise) and exposes
// {stage, done, total} to any poller (the studio's job panel).
#pragma once
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace btf {

/// What a poller (the studio's job panel) sees of the running job: the current stage and its
/// counter. A job thread installs one with ProgressReporter::observe(); every reporter created on
/// that thread publishes into it, whichever worker calls add().
struct ProgressState {
  mutable std::mutex mutex;
  std::string stage;  // guarded by mutex
  std::atomic<int64_t> done{0}, total{1};
  std::atomic<int> stages{0};                        // reporters started so far
  std::chrono::steady_clock::time_point stageStart;  // guarded by mutex
  /// Called on the running thread as each stage starts (tests cancel at a stage with it).
  std::function<void(const std::string& stage)> onStage;
  std::string currentStage() const {
    std::lock_guard lock(mutex);
    return stage;
  }
};

class ProgressReporter {
 public:
  /// Installs `state` as the observer of reporters created on this thread (nullptr: none);
  /// returns the previous one.
  static ProgressState* observe(ProgressState* state);
  ProgressReporter(std::string stage, int64_t total, bool print);
  ~ProgressReporter();
  void add(int64_t n);
  void finish();
  int64_t done() const { return m_done.load(std::memory_order_relaxed); }
  int64_t total() const { return m_total; }
  double elapsedSeconds() const;

 private:
  void draw(bool final);
  std::string m_stage;
  int64_t m_total;
  bool m_print;
  bool m_tty;
  bool m_finished = false;
  std::atomic<int64_t> m_done{0};
  std::chrono::steady_clock::time_point m_start;
  std::chrono::steady_clock::time_point m_lastDraw;
  int m_lastDecile = -1;
  std::mutex m_mutex;
  ProgressState* m_observer = nullptr;
};

}  // namespace btf
