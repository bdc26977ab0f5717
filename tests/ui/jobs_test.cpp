// The job queue: jobs run one after another on the worker, publish progress through the
// engine's ProgressReporter, cancel cooperatively (queued jobs never start), report errors
// without throwing, clean up after failures, and hand results back on the main thread.
#include <btf/core/error.h>
#include <gtest/gtest.h>
#include <ui/jobs.h>

#include <thread>

using namespace btf;
using namespace btf::ui;

namespace {
std::unique_ptr<Job> makeJob(std::function<std::string(Job&)> f) {
  auto j = std::make_unique<Job>();
  j->kind = j->title = "test";
  j->run = std::move(f);
  return j;
}
}  // namespace

TEST(Jobs, RunInOrderPublishProgressAndReturnResultsOnThePumpingThread) {
  JobQueue q;
  std::vector<int> order;
  std::mutex m;
  const auto mainId = std::this_thread::get_id();
  std::thread::id doneOn;
  auto a = makeJob([&](Job& j) {
    ProgressReporter pr("stage one", 100, false);
    for (int i = 0; i < 100; ++i) pr.add(1);
    EXPECT_EQ(j.progress.currentStage(), "stage one");
    EXPECT_EQ(j.progress.done.load(), 100);
    std::lock_guard lock(m);
    order.push_back(1);
    return std::string("first");
  });
  a->onDone = [&](Job&) { doneOn = std::this_thread::get_id(); };
  const int ida = q.submit(std::move(a));
  const int idb = q.submit(makeJob([&](Job&) {
    std::lock_guard lock(m);
    order.push_back(2);
    return std::string("second");
  }));
  ASSERT_TRUE(q.waitAll(30));
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
  EXPECT_EQ(q.find(ida)->status.load(), JobStatus::Done);
  EXPECT_EQ(q.find(ida)->message, "first");
  EXPECT_EQ(q.find(idb)->message, "second");
  EXPECT_EQ(doneOn, mainId);
  EXPECT_DOUBLE_EQ(q.find(ida)->fraction(), 1.0);
}

TEST(Jobs, CancelStopsTheRunningJobAndQueuedJobsNeverStart) {
  JobQueue q;
  std::atomic<bool> started{false}, secondRan{false}, cleaned{false};
  auto a = makeJob([&](Job& j) {
    started = true;
    while (!j.cancel.cancelled()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return std::string("stopped");
  });
  a->cleanup = [&](Job&) { cleaned = true; };
  const int ida = q.submit(std::move(a));
  const int idb = q.submit(makeJob([&](Job&) {
    secondRan = true;
    return std::string();
  }));
  while (!started) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  q.cancel(idb);
  q.cancel(ida);
  ASSERT_TRUE(q.waitAll(10));
  EXPECT_EQ(q.find(ida)->status.load(), JobStatus::Cancelled);
  EXPECT_EQ(q.find(idb)->status.load(), JobStatus::Cancelled);
  EXPECT_FALSE(secondRan);
  EXPECT_TRUE(cleaned);
}

TEST(Jobs, ErrorsBecomeMessagesAndTheQueueGoesOn) {
  JobQueue q;
  bool doneCalled = false;
  auto a =
      makeJob([](Job&) -> std::string { throw Error("scene.json: parts[0].size: must be > 0"); });
  a->onDone = [&](Job&) { doneCalled = true; };
  const int ida = q.submit(std::move(a));
  const int idb = q.submit(makeJob([](Job&) { return std::string("fine"); }));
  ASSERT_TRUE(q.waitAll(10));
  EXPECT_EQ(q.find(ida)->status.load(), JobStatus::Failed);
  EXPECT_NE(q.find(ida)->message.find("parts[0].size"), std::string::npos);
  EXPECT_FALSE(doneCalled);
  EXPECT_EQ(q.find(idb)->status.load(), JobStatus::Done);
  q.clearFinished();
  EXPECT_TRUE(q.jobs().empty());
}
