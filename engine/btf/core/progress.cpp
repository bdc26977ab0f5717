#include <btf/core/progress.h>
#include <btf/core/sysinfo.h>
#include <unistd.h>

#include <cstdio>

namespace btf {

namespace {
thread_local ProgressState* t_observer = nullptr;
}

ProgressState* ProgressReporter::observe(ProgressState* state) {
  ProgressState* prev = t_observer;
  t_observer = state;
  return prev;
}

ProgressReporter::ProgressReporter(std::string stage, int64_t total, bool print)
    : m_stage(std::move(stage)), m_total(total < 1 ? 1 : total), m_print(print) {
  m_tty = isatty(STDERR_FILENO) != 0;
  m_start = m_lastDraw = std::chrono::steady_clock::now();
  m_observer = t_observer;
  if (m_observer) {
    std::lock_guard lock(m_observer->mutex);
    m_observer->stage = m_stage;
    m_observer->stageStart = m_start;
    m_observer->done = 0;
    m_observer->total = m_total;
    ++m_observer->stages;
  }
  if (m_observer && m_observer->onStage) m_observer->onStage(m_stage);
}

ProgressReporter::~ProgressReporter() {
  if (!m_finished && m_print && m_tty) std::fprintf(stderr, "\n");
}

double ProgressReporter::elapsedSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
}

void ProgressReporter::add(int64_t n) {
  m_done.fetch_add(n, std::memory_order_relaxed);
  if (m_observer) m_observer->done.fetch_add(n, std::memory_order_relaxed);
  if (!m_print) return;
  std::unique_lock lock(m_mutex, std::try_to_lock);
  if (!lock.owns_lock()) return;
  draw(false);
}

void ProgressReporter::finish() {
  if (m_finished) return;
  m_finished = true;
  if (m_observer) m_observer->done = m_total;
  if (!m_print) return;
  std::lock_guard lock(m_mutex);
  m_done = m_total;
  draw(true);
}

void ProgressReporter::draw(bool final) {
  auto now = std::chrono::steady_clock::now();
  const double frac = std::min(1.0, double(done()) / double(m_total));
  const double el = std::chrono::duration<double>(now - m_start).count();
  if (m_tty) {
    if (!final && std::chrono::duration<double>(now - m_lastDraw).count() < 0.2) return;
  } else {
    // A stage shorter than a second prints its final line only; longer ones a line per 10 %,
    // and the 100 % line once (finish() after the last add() draws nothing new).
    if (!final && el < 1.0) return;
    const int decile = int(frac * 10);
    if (decile == m_lastDecile && (!final || decile == 10)) return;
    m_lastDecile = decile;
  }
  m_lastDraw = now;
  const int width = 30;
  std::string bar(width, ' ');
  for (int i = 0; i < int(frac * width); ++i) bar[i] = '#';
  // An ETA from the first percent of a stage is noise (set-up costs dominate): say so instead.
  const bool known = frac >= 0.05 && el >= 0.5;
  const std::string eta = final || frac >= 1 ? "done"
                          : known            ? "ETA " + formatSeconds(el * (1 - frac) / frac)
                                             : "ETA …";
  std::fprintf(stderr, "%s%-14s [%s] %5.1f%%  %s elapsed, %s%s", m_tty ? "\r" : "", m_stage.c_str(),
               bar.c_str(), 100 * frac, formatSeconds(el).c_str(), eta.c_str(),
               (m_tty && !final) ? "" : "\n");
  std::fflush(stderr);
}

}  // namespace btf
