// The live previews' background worker: one thread that runs the preview use case
// (engine/btf/ops/preview.h) for the latest request. Every request supersedes the previous one:
// its stages are cancelled and restarted, and a superseded stage is never shown.
#pragma once
#include <btf/core/math.h>
#include <btf/core/parallel.h>
#include <btf/ops/preview.h>

#include <array>
#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace btf::ui {

using PreviewRequest = ops::PreviewRequest;
using PreviewResult = ops::PreviewResult;
using ops::curveDirection;

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

}  // namespace btf::ui
