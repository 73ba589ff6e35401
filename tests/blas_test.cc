// Which library the BLAS calls of the `colmap` binary reach (CMakeLists.txt,
// "BLAS"): the system's libblas.so.3 (OpenBLAS after scripts/setup.sh), not
// ATLAS's libf77blas that Debian's Ceres links too and that exports the same
// symbols.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>

#include "tests/support/test_paths.h"

namespace glomap {
namespace {

// The dynamic linker's bindings of CHOLMOD's BLAS calls in `colmap help`
// (LD_BIND_NOW binds every symbol at start-up, LD_DEBUG logs each binding):
// symbol -> canonical path of the library that provides it.
std::map<std::string, std::string> CholmodBlasBindings(
    const std::string& log_prefix) {
  const std::string command =
      "LD_BIND_NOW=1 LD_DEBUG=bindings LD_DEBUG_OUTPUT=" + log_prefix + " " +
      testing::ColmapExecutable() + " help";
  EXPECT_EQ(testing::RunCommand(command), 0) << command;
  const std::regex binding(
      "binding file \\S*libcholmod\\.so\\S* \\[\\d+\\] to (\\S+) \\[\\d+\\]: "
      "normal symbol `(dgemm_|dsyrk_|dtrsm_)'");
  std::map<std::string, std::string> bindings;
  const std::filesystem::path dir =
      std::filesystem::path(log_prefix).parent_path();
  const std::string stem = std::filesystem::path(log_prefix).filename();
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().filename().string().rfind(stem, 0) != 0) continue;
    std::ifstream file(entry.path());
    std::string line;
    std::smatch match;
    while (std::getline(file, line)) {
      if (std::regex_search(line, match, binding)) {
        bindings[match[2]] =
            std::filesystem::canonical(match[1].str()).string();
      }
    }
  }
  return bindings;
}

TEST(Blas, CholmodCallsReachTheSystemsLibblas) {
  const std::string dir = testing::CreateTestDir("blas_test");
  const std::map<std::string, std::string> bindings =
      CholmodBlasBindings(dir + "/ld_debug");
  const std::string system_blas =
      std::filesystem::canonical("/usr/lib/x86_64-linux-gnu/libblas.so.3")
          .string();
  for (const char* symbol : {"dgemm_", "dsyrk_", "dtrsm_"}) {
    ASSERT_TRUE(bindings.count(symbol)) << symbol << " is not bound";
    EXPECT_EQ(bindings.at(symbol), system_blas) << symbol;
  }
}

}  // namespace
}  // namespace glomap
