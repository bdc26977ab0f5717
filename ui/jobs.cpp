#include "jobs.h"

#include <btf/core/error.h>
#include <btf/core/run_context.h>
#include <btf/core/sysinfo.h>

namespace btf::ui {

using Clock = std::chrono::steady_clock;

const char* jobStatusName(JobStatus s) {
  switch (s) {
    case JobStatus::Queued:
      return "queued";
    case JobStatus::Running:
      return "running";
    case JobStatus::Done:
      return "done";
    case JobStatus::Failed:
      return "failed";
    case JobStatus::Cancelled:
      return "cancelled";
  }
  return "?";
}

double Job::elapsedSeconds() const {
  const JobStatus s = status.load();
  if (s == JobStatus::Queued) return 0;
  const auto end = (s == JobStatus::Running) ? Clock::now() : finished;
  return std::chrono::duration<double>(end - started).count();
}

double Job::fraction() const {
  const double t = double(progress.total.load());
  return t > 0 ? std::min(1.0, double(progress.done.load()) / t) : 0.0;
}

double Job::etaSeconds() const {
  if (status.load() != JobStatus::Running) return -1;
  const double f = fraction();
  Clock::time_point start;
  {
    std::lock_guard lock(progress.mutex);
    start = progress.stageStart;
  }
  const double el = std::chrono::duration<double>(Clock::now() - start).count();
  if (f <= 0.01 || el < 0.2) return -1;
  return el * (1 - f) / f;
}

JobQueue::JobQueue() {
  m_thread = std::thread([this] { worker(); });
}

JobQueue::~JobQueue() {
  {
    std::lock_guard lock(m_mutex);
    m_stop = true;
    for (auto& j : m_jobs) j->cancel.cancel();
  }
  m_cv.notify_all();
  if (m_thread.joinable()) m_thread.join();
}

int JobQueue::submit(std::unique_ptr<Job> job) {
  std::shared_ptr<Job> j(std::move(job));
  {
    std::lock_guard lock(m_mutex);
    j->id = m_nextId++;
    m_jobs.push_back(j);
    m_pending.push_back(j);
  }
  m_cv.notify_all();
  return j->id;
}

void JobQueue::cancel(int id) {
  std::lock_guard lock(m_mutex);
  for (auto it = m_pending.begin(); it != m_pending.end(); ++it)
    if ((*it)->id == id) {
      (*it)->status = JobStatus::Cancelled;
      (*it)->message = "cancelled before it started";
      m_pending.erase(it);
      return;
    }
  for (auto& j : m_jobs)
    if (j->id == id) j->cancel.cancel();
}

void JobQueue::cancelAll() {
  std::vector<int> ids;
  {
    std::lock_guard lock(m_mutex);
    for (auto& j : m_jobs) ids.push_back(j->id);
  }
  for (int id : ids) cancel(id);
}

void JobQueue::pump() {
  std::deque<std::function<void()>> q;
  {
    std::lock_guard lock(m_mutex);
    q.swap(m_mainQueue);
  }
  for (auto& f : q) f();
}

bool JobQueue::busy() const {
  std::lock_guard lock(m_mutex);
  return m_current != nullptr || !m_pending.empty() || !m_mainQueue.empty();
}

bool JobQueue::waitAll(double seconds) {
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (busy() && Clock::now() < end) {
    pump();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  pump();
  return !busy();
}

std::vector<std::shared_ptr<Job>> JobQueue::jobs() const {
  std::lock_guard lock(m_mutex);
  return m_jobs;
}

std::shared_ptr<Job> JobQueue::find(int id) const {
  std::lock_guard lock(m_mutex);
  for (auto& j : m_jobs)
    if (j->id == id) return j;
  return nullptr;
}

void JobQueue::clearFinished() {
  std::lock_guard lock(m_mutex);
  std::erase_if(m_jobs, [](const std::shared_ptr<Job>& j) {
    const JobStatus s = j->status.load();
    return s == JobStatus::Done || s == JobStatus::Failed || s == JobStatus::Cancelled;
  });
}

void JobQueue::worker() {
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock lock(m_mutex);
      m_cv.wait(lock, [&] { return m_stop || !m_pending.empty(); });
      if (m_stop) return;
      job = m_pending.front();
      m_pending.pop_front();
      m_current = job;
    }
    job->started = Clock::now();
    job->status = JobStatus::Running;
    ProgressState* prev = ProgressReporter::observe(&job->progress);
    JobStatus end = JobStatus::Done;
    try {
      job->message = job->run(*job);
      if (job->cancel.cancelled()) {
        end = JobStatus::Cancelled;
        job->message = "cancelled";
      }
    } catch (const Cancelled&) {
      end = JobStatus::Cancelled;
      job->message = "cancelled";
    } catch (const std::exception& e) {
      end = job->cancel.cancelled() ? JobStatus::Cancelled : JobStatus::Failed;
      job->message = job->cancel.cancelled() ? "cancelled" : e.what();
    }
    ProgressReporter::observe(prev);
    if (end != JobStatus::Done && job->cleanup) {
      try {
        job->cleanup(*job);
      } catch (const std::exception& e) {
        job->message += std::string(" (cleanup: ") + e.what() + ")";
      }
    }
    job->peakRss = peakRssBytes();
    job->finished = Clock::now();
    job->status = end;
    std::lock_guard lock(m_mutex);
    if (end == JobStatus::Done && job->onDone) m_mainQueue.push_back([job] { job->onDone(*job); });
    m_current = nullptr;
  }
}

}  // namespace btf::ui
