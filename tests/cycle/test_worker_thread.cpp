// The pipeline's processing thread (cycle/worker_thread.hpp): one persistent thread runs every job,
// a job's exception reaches the owner, the destructor finishes a running job and joins, and the
// pipeline keeps using that one thread cycle after cycle.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

#include "binpick/cycle/worker_thread.hpp"

using binpick::cycle::detail::WorkerThread;

TEST(WorkerThread, RunsEveryJobOnOneThreadOtherThanTheCaller) {
  WorkerThread w;
  std::vector<std::thread::id> ids;
  for (int k = 0; k < 50; ++k) {
    w.start([&ids] { ids.push_back(std::this_thread::get_id()); });
    w.wait();
  }
  ASSERT_EQ(ids.size(), 50u);
  EXPECT_NE(ids[0], std::this_thread::get_id());
  for (const auto& id : ids) EXPECT_EQ(id, ids[0]);
}

TEST(WorkerThread, PassesAJobsExceptionToTheOwnerAndStaysUsable) {
  WorkerThread w;
  w.start([] { throw std::runtime_error("job failed"); });
  EXPECT_THROW(w.wait(), std::runtime_error);
  EXPECT_NO_THROW(w.wait());  // reported once
  int ran = 0;
  w.start([&ran] { ++ran; });
  EXPECT_NO_THROW(w.wait());
  EXPECT_EQ(ran, 1);
}

TEST(WorkerThread, DestructorFinishesTheRunningJob) {
  std::atomic<int> done{0};
  {
    WorkerThread w;
    w.start([&done] {
      for (int i = 0; i < 1000; ++i) std::this_thread::yield();
      done = 1;
    });
  }  // no wait(): the destructor must let the job end before it joins
  EXPECT_EQ(done.load(), 1);
  WorkerThread never_started;  // destroying a worker that never ran a job is fine too
  (void)never_started;
}

TEST(WorkerThread, ACopyIsAnIdleWorkerOfItsOwn) {
  WorkerThread a;
  std::thread::id ia, ib;
  a.start([&ia] { ia = std::this_thread::get_id(); });
  a.wait();
  WorkerThread b(a);
  b.start([&ib] { ib = std::this_thread::get_id(); });
  b.wait();
  EXPECT_NE(ia, ib);
}
