// Runs a loop body on a COLMAP thread pool in contiguous chunks.
#pragma once

#include <algorithm>
#include <cstddef>

#include "util/threading.h"

namespace glomap {

// Calls fn(i) for every i in [0, n), on `num_threads` threads (-1: all
// cores). Each i is visited exactly once; the order across chunks is not
// defined, so `fn` must write only to slot i of its outputs.
template <typename Fn>
void ParallelFor(int num_threads, size_t n, const Fn& fn) {
  const int threads = colmap::GetEffectiveNumThreads(num_threads);
  if (threads <= 1 || n < 2) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  colmap::ThreadPool pool(threads);
  // A few chunks per thread balance uneven work without a task per item.
  const size_t num_chunks = std::min<size_t>(n, 8 * threads);
  for (size_t chunk = 0; chunk < num_chunks; ++chunk) {
    pool.AddTask([&fn, n, num_chunks, chunk]() {
      const size_t begin = n * chunk / num_chunks;
      const size_t end = n * (chunk + 1) / num_chunks;
      for (size_t i = begin; i < end; ++i) fn(i);
    });
  }
  pool.Wait();
}

}  // namespace glomap
