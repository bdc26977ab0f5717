// Background jobs of the studio (simulate, compress, study, export): a queue run by one worker
// thread, each job publishing {stage, done, total} through btf::ProgressState and polled by the
// UI every frame. Cancel is cooperative (btf::CancelToken); results come back to the main thread
// through a queue of callbacks (Tracy's RunQueue), so GL uploads stay on the main thread.
#pragma once
#include <btf/core/parallel.h>
#include <btf/core/progress.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace btf::ui {

enum class JobStatus { Queued, Running, Done, Failed, Cancelled };
const char* jobStatusName(JobStatus s);

struct Job {
  int id = 0;
  std::string kind, title;
  std::string estimate;  // time / memory / disk, shown before and while it runs
  std::string output;    // the file or folder it writes
  /// Runs on the worker thread; throws btf::Error on failure; returns a one-line summary.
  std::function<std::string(Job&)> run;
  /// Runs on the main thread after a successful run (opens the result in an inspector).
  std::function<void(Job&)> onDone;
  /// Removes what a cancelled or failed run left (partial files).
  std::function<void(Job&)> cleanup;

  ProgressState progress;
  CancelToken cancel;
  std::atomic<JobStatus> status{JobStatus::Queued};
  std::atomic<uint64_t> peakRss{0};
  std::atomic<bool> keepPartial{false};  // "stop": cancel but keep the partial file to resume
  std::chrono::steady_clock::time_point started, finished;
  std::string message;  // summary or error (set by the worker before the status changes)

  double elapsedSeconds() const;
  /// Fraction of the current stage and an ETA from its rate (negative when unknown).
  double fraction() const;
  double etaSeconds() const;
};

class JobQueue {
 public:
  JobQueue();
  ~JobQueue();  // cancels everything and joins the worker
  /// Queues a job; returns its id.
  int submit(std::unique_ptr<Job> job);
  void cancel(int id);
  void cancelAll();
  /// Runs the callbacks the worker posted (call once per frame on the main thread).
  void pump();
  /// True while a job is queued or running.
  bool busy() const;
  /// Blocks (pumping) until every job has ended or `seconds` passed; returns !busy().
  bool waitAll(double seconds);
  /// Snapshot of the jobs (shared pointers: the panel reads them while the worker runs).
  std::vector<std::shared_ptr<Job>> jobs() const;
  std::shared_ptr<Job> find(int id) const;
  void clearFinished();

 private:
  void worker();
  mutable std::mutex m_mutex;
  std::condition_variable m_cv;
  std::vector<std::shared_ptr<Job>> m_jobs;
  std::deque<std::shared_ptr<Job>> m_pending;
  std::deque<std::function<void()>> m_mainQueue;
  std::shared_ptr<Job> m_current;
  bool m_stop = false;
  int m_nextId = 1;
  std::thread m_thread;
};

}  // namespace btf::ui
