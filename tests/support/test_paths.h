// Where tests find the built `colmap` binary, the shared datasets and a
// scratch folder.
#pragma once

#include <string>

namespace glomap {
namespace testing {

// The `colmap` executable of this build.
std::string ColmapExecutable();

// ../shared/datasets beside the source tree, or "" when it is absent. Tests
// that need it call GTEST_SKIP() when this is empty.
std::string SharedDatasetsDir();

// A fresh, empty folder under the build tree for one test.
std::string CreateTestDir(const std::string& name);

// Runs a shell command, returns its exit status; stdout+stderr go to
// `output` when it is not null.
int RunCommand(const std::string& command, std::string* output = nullptr);

// Hex SHA-256-like digest of a file's bytes (FNV-1a 64 over the content;
// enough to detect any change in a test).
std::string FileDigest(const std::string& path);

}  // namespace testing
}  // namespace glomap
