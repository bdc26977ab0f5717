#include "preview.h"

#include <btf/core/error.h>
#include <btf/core/run_context.h>


namespace btf::ui {

PreviewWorker::PreviewWorker() {
  m_thread = std::thread([this] { loop(); });
}

PreviewWorker::~PreviewWorker() {
  {
    std::lock_guard lock(m_mutex);
    m_stop = true;
    if (m_cancel) m_cancel->cancel();
  }
  m_cv.notify_all();
  m_thread.join();
}

uint64_t PreviewWorker::request(const PreviewRequest& r) {
  std::lock_guard lock(m_mutex);
  if (m_cancel) m_cancel->cancel();
  m_req = r;
  m_has = true;
  ++m_gen;
  m_cv.notify_all();
  return m_gen;
}

bool PreviewWorker::poll(PreviewResult* out) {
  std::lock_guard lock(m_mutex);
  if (!m_changed) return false;
  *out = m_result;
  m_changed = false;
  return true;
}

bool PreviewWorker::working() const {
  std::lock_guard lock(m_mutex);
  return m_has || m_doneGen != m_gen;
}

void PreviewWorker::publish(const std::function<void(PreviewResult&)>& f, uint64_t gen) {
  std::lock_guard lock(m_mutex);
  if (gen != m_gen) return;  // superseded: never show a stale stage
  if (m_result.generation != gen) {
    m_result = PreviewResult{};
    m_result.generation = gen;
  }
  f(m_result);
  m_changed = true;
}

void PreviewWorker::loop() {
  for (;;) {
    PreviewRequest r;
    uint64_t gen;
    std::shared_ptr<CancelToken> cancel;
    {
      std::unique_lock lock(m_mutex);
      m_cv.wait(lock, [&] { return m_stop || m_has; });
      if (m_stop) return;
      r = m_req;
      gen = m_gen;
      m_has = false;
      cancel = m_cancel = std::make_shared<CancelToken>();
    }
    try {
      runGeneration(r, gen, *cancel);
    } catch (const Cancelled&) {
      // superseded by a newer request: nothing to report
    } catch (const std::exception& e) {
      publish([&](PreviewResult& res) { res.error = e.what(); }, gen);
    }
    publish([&](PreviewResult& res) { res.done = !cancel->cancelled(); }, gen);
    std::lock_guard lock(m_mutex);
    m_doneGen = gen;
  }
}
void PreviewWorker::runGeneration(const PreviewRequest& r, uint64_t gen,
                                  const CancelToken& cancel) {
  ops::runPreview(r, cancel, [&](const std::function<void(PreviewResult&)>& f) { publish(f, gen); });
}

}  // namespace btf::ui
