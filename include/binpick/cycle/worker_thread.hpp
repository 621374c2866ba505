#pragma once
/// \file worker_thread.hpp
/// One persistent thread that runs one job at a time: the data processing of each cycle (Fig. 2,
/// step 2) runs on it while the robot places the part. A thread per cycle would hand every cycle a
/// fresh thread — a fresh allocator cache, a fresh OpenMP pool when processing runs on several
/// threads — and over a shift that churn shows up as resident memory that creeps. The thread starts
/// with the first job and is joined by the destructor.

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>

namespace binpick::cycle::detail {

class WorkerThread {
 public:
  WorkerThread() = default;
  /// A copy is a new idle worker: the thread is not part of the owner's value.
  WorkerThread(const WorkerThread&) : WorkerThread() {}
  WorkerThread& operator=(const WorkerThread&) { return *this; }
  ~WorkerThread() {
    {
      std::unique_lock<std::mutex> lock(m_);
      done_.wait(lock, [this] { return !busy_; });  // never stop in the middle of a job
      stop_ = true;
    }
    wake_.notify_one();
    if (thread_.joinable()) thread_.join();
  }

  /// Hands `job` to the thread and returns at once. Precondition: the previous job was waited for.
  /// Throws std::system_error when the thread cannot be started (nothing runs then).
  void start(std::function<void()> job) {
    if (!thread_.joinable()) thread_ = std::thread([this] { loop(); });
    {
      std::lock_guard<std::mutex> lock(m_);
      job_ = std::move(job);
      error_ = nullptr;
      busy_ = true;
    }
    wake_.notify_one();
  }

  /// Blocks until the job handed by start() has ended; rethrows what it threw.
  void wait() {
    std::unique_lock<std::mutex> lock(m_);
    done_.wait(lock, [this] { return !busy_; });
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(m_);
    for (;;) {
      wake_.wait(lock, [this] { return stop_ || busy_; });
      if (!busy_) return;  // stop_ with nothing to do
      std::function<void()> job = std::move(job_);
      job_ = nullptr;
      lock.unlock();
      std::exception_ptr error;
      try {
        job();
      } catch (...) {
        error = std::current_exception();
      }
      job = nullptr;  // the job's captures die on this thread, before the owner is told
      lock.lock();
      error_ = error;
      busy_ = false;
      done_.notify_all();
    }
  }

  std::mutex m_;
  std::condition_variable wake_, done_;
  std::function<void()> job_;
  std::exception_ptr error_;
  bool busy_ = false, stop_ = false;
  std::thread thread_;  // last: started after the members it reads are initialized
};

}  // namespace binpick::cycle::detail
