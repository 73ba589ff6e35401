#include "glomap/ceres_threads.h"

#include <gtest/gtest.h>

namespace glomap {
namespace {

TEST(CeresNumThreads, SmallProblemsRunOnOneThread) {
  EXPECT_EQ(CeresNumThreads(8, 0), 1);
  EXPECT_EQ(CeresNumThreads(8, kMinResidualBlocksPerCeresThread - 1), 1);
}

TEST(CeresNumThreads, OneMoreThreadPerBlockOfResiduals) {
  EXPECT_EQ(CeresNumThreads(8, kMinResidualBlocksPerCeresThread), 2);
  EXPECT_EQ(CeresNumThreads(8, 3 * kMinResidualBlocksPerCeresThread), 4);
}

TEST(CeresNumThreads, NeverMoreThanTheUserAllows) {
  EXPECT_EQ(CeresNumThreads(1, 100 * kMinResidualBlocksPerCeresThread), 1);
  EXPECT_EQ(CeresNumThreads(3, 100 * kMinResidualBlocksPerCeresThread), 3);
  // -1 means all cores: at least one thread, at most the machine's.
  const int all = CeresNumThreads(-1, 100 * kMinResidualBlocksPerCeresThread);
  EXPECT_GE(all, 1);
  EXPECT_EQ(all, colmap::GetEffectiveNumThreads(-1));
}

}  // namespace
}  // namespace glomap
