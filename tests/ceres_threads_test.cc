#include "glomap/util/ceres_threads.h"

#include <gtest/gtest.h>

namespace glomap {
namespace {

constexpr int kPerThread = kMinResidualBlocksPerCeresThread;

TEST(CeresNumThreads, SmallProblemsRunOnOneThread) {
  EXPECT_EQ(CeresNumThreads(8, 0, kPerThread), 1);
  EXPECT_EQ(CeresNumThreads(8, kPerThread - 1, kPerThread), 1);
}

TEST(CeresNumThreads, OneMoreThreadPerBlockOfResiduals) {
  EXPECT_EQ(CeresNumThreads(8, kPerThread, kPerThread), 2);
  EXPECT_EQ(CeresNumThreads(8, 3 * kPerThread, kPerThread), 4);
  // GlobalMapper.min_residuals_per_ceres_thread sets the block size.
  EXPECT_EQ(CeresNumThreads(8, 1000, 500), 3);
  EXPECT_EQ(CeresNumThreads(8, 1000, 1), 8);
}

TEST(CeresNumThreads, NeverMoreThanTheUserAllows) {
  EXPECT_EQ(CeresNumThreads(1, 100 * kPerThread, kPerThread), 1);
  EXPECT_EQ(CeresNumThreads(3, 100 * kPerThread, kPerThread), 3);
  // -1 means all cores: at least one thread, at most the machine's.
  const int all = CeresNumThreads(-1, 100 * kPerThread, kPerThread);
  EXPECT_GE(all, 1);
  EXPECT_EQ(all, colmap::GetEffectiveNumThreads(-1));
}

}  // namespace
}  // namespace glomap
