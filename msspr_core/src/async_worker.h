// One persistent background thread that runs one task at a time (the
// trainer's pipelined actor-critic update). Wait() blocks until the task
// has finished and rethrows its exception, if any. Not copyable; the
// destructor waits for the running task and joins the thread.
#pragma once
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace msspr {
namespace core {

class AsyncWorker {
 public:
  AsyncWorker() : thread_([this] { Loop(); }) {}
  ~AsyncWorker() {
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [this] { return !busy_; });
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  AsyncWorker(const AsyncWorker&) = delete;
  AsyncWorker& operator=(const AsyncWorker&) = delete;

  // Starts `task` on the worker thread; waits for the previous one first
  // (its exception, if any, is rethrown here and `task` is not started).
  void Run(std::function<void()> task) {
    Wait();
    {
      std::lock_guard<std::mutex> lock(mu_);
      task_ = std::move(task);
      busy_ = true;
    }
    cv_.notify_all();
  }

  // Blocks until no task is running; rethrows the exception of the last one.
  void Wait() {
    std::exception_ptr error;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [this] { return !busy_; });
      std::swap(error, error_);
    }
    if (error) std::rethrow_exception(error);
  }

  bool busy() const {
    std::lock_guard<std::mutex> lock(mu_);
    return busy_;
  }

 private:
  void Loop() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mu_);
        cv_.wait(lock, [this] { return busy_ || stop_; });
        if (stop_ && !busy_) return;
        task = std::move(task_);
      }
      std::exception_ptr error;
      try {
        task();
      } catch (...) {
        error = std::current_exception();
      }
      {
        std::lock_guard<std::mutex> lock(mu_);
        error_ = error;
        busy_ = false;
      }
      cv_.notify_all();
    }
  }

  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::function<void()> task_;
  std::exception_ptr error_;
  bool busy_ = false;
  bool stop_ = false;
  std::thread thread_;  // last: started after the other members exist
};

}  // namespace core
}  // namespace msspr
