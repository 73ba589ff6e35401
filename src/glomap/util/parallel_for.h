// Runs a loop body on several threads in contiguous chunks.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

#include "glomap/util/ceres_threads.h"
#include "util/threading.h"

namespace glomap {

// Calls fn(i) for every i in [0, n), on `num_threads` threads (-1: all
// cores), the calling thread included. Each i is visited exactly once; the
// order across chunks is not defined, so `fn` must write only to slot i of
// its outputs. The first exception thrown by `fn` is rethrown here once all
// threads are done. OpenMP regions inside `fn` (Eigen's, a library's) run on
// the thread that enters them (see ScopedSerialOpenMp), so that no more than
// `num_threads` threads compute.
//
// Not colmap::ThreadPool: its futures swallow a task's exception (the output
// would be silently incomplete), and its constructor hangs when the system
// refuses a thread (it destroys a condition variable a started worker waits
// on). Here a thread that cannot be started only means fewer threads.
template <typename Fn>
void ParallelFor(int num_threads, size_t n, const Fn& fn) {
  const ScopedSerialOpenMp serial_openmp;
  const int threads = colmap::GetEffectiveNumThreads(num_threads);
  if (threads <= 1 || n < 2) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  // A few chunks per thread balance uneven work without a task per item.
  const size_t num_chunks = std::min<size_t>(n, 8 * threads);
  std::atomic<size_t> next_chunk(0);
  std::mutex error_mutex;
  std::exception_ptr error;
  const auto work = [&]() {
    for (size_t chunk = next_chunk++; chunk < num_chunks;
         chunk = next_chunk++) {
      try {
        const size_t begin = n * chunk / num_chunks;
        const size_t end = n * (chunk + 1) / num_chunks;
        for (size_t i = begin; i < end; ++i) fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> workers;
  workers.reserve(threads - 1);
  for (int t = 1; t < threads; ++t) {
    try {
      workers.emplace_back([&work]() {
        ScopedSerialOpenMp::SetSerialOpenMpOnThisThread();
        work();
      });
    } catch (const std::system_error&) {
      break;
    }
  }
  work();
  for (std::thread& worker : workers) worker.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace glomap
