#include "glomap/util/parallel_for.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace glomap {
namespace {

TEST(ParallelFor, VisitsEveryIndexOnce) {
  for (const int num_threads : {1, 3, -1}) {
    for (const size_t n : {0, 1, 2, 7, 1000}) {
      std::vector<std::atomic<int>> visits(n);
      ParallelFor(num_threads, n, [&](size_t i) { ++visits[i]; });
      for (size_t i = 0; i < n; ++i) {
        EXPECT_EQ(visits[i], 1) << i << " of " << n;
      }
    }
  }
}

// An exception in the body reaches the caller (COLMAP's ThreadPool kept it
// in a future nobody read, leaving the output silently incomplete), once
// every thread is done.
TEST(ParallelFor, RethrowsTheBodysException) {
  for (const int num_threads : {1, 4}) {
    std::vector<std::atomic<int>> visits(100);
    EXPECT_THROW(ParallelFor(num_threads, visits.size(),
                             [&](size_t i) {
                               if (i == 37) throw std::runtime_error("37");
                               ++visits[i];
                             }),
                 std::runtime_error);
    EXPECT_EQ(visits[36], 1);
    // On several threads, the chunks after the failed one still ran.
    if (num_threads > 1) {
      EXPECT_EQ(visits[99], 1);
    }
  }
}

}  // namespace
}  // namespace glomap
