#include "tests/support/test_paths.h"

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace glomap {
namespace testing {

std::string ColmapExecutable() { return GLOMAP_COLMAP_EXE; }

std::string SharedDatasetsDir() {
  if (const char* env = std::getenv("GLOMAP_SHARED_DATASETS")) {
    return std::filesystem::is_directory(env) ? std::string(env) : "";
  }
  const std::filesystem::path path =
      std::filesystem::path(GLOMAP_SOURCE_DIR) / ".." / "shared" / "datasets";
  if (!std::filesystem::is_directory(path)) return "";
  return std::filesystem::canonical(path).string();
}

std::string CreateTestDir(const std::string& name) {
  const std::filesystem::path path =
      std::filesystem::path(GLOMAP_BINARY_DIR) / "test_tmp" / name;
  std::filesystem::remove_all(path);
  std::filesystem::create_directories(path);
  return path.string();
}

int RunCommand(const std::string& command, std::string* output) {
  const std::string full = "( " + command + " ) 2>&1";
  FILE* pipe = popen(full.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer;
  std::string text;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) {
    text.append(buffer.data(), n);
  }
  const int status = pclose(pipe);
  if (output != nullptr) *output = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

std::string FileDigest(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  uint64_t hash = 1469598103934665603ull;
  char c;
  while (file.get(c)) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ull;
  }
  std::ostringstream out;
  out << std::hex << std::setw(16) << std::setfill('0') << hash;
  return out.str();
}

}  // namespace testing
}  // namespace glomap
