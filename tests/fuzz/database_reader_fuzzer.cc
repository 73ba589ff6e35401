// libFuzzer target for glomap::ReadDatabase: every input is written to a
// temporary file (in /dev/shm when possible) and read as a COLMAP 3.8
// database with the default options. The reader must turn any file into a
// Status: a crash, an abort (CHECK), an escaping exception, a leak, a
// sanitizer report or a slow input is a finding. Built and run by
// scripts/fuzz.sh (see tests/fuzz/README.md).
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "base/reconstruction.h"
#include "glomap/io/database_reader.h"
#include "glomap/scene/view_graph.h"
#include "util/logging.h"

namespace {

// The temporary file of this process; one per process, rewritten for every
// input, so that parallel fuzzing jobs (-jobs/-workers) never share one.
std::string g_path;

// GLOMAP_FUZZ_VERBOSE=1 prints the reader's log and each input's Status, to
// triage a reproducer (e.g. database_reader_fuzzer FILE).
bool g_verbose = false;

std::string TempDir() {
  const char* const dirs[] = {"/dev/shm", std::getenv("TMPDIR"), "/tmp"};
  for (const char* dir : dirs) {
    if (dir != nullptr && *dir != '\0' && access(dir, W_OK) == 0) return dir;
  }
  return ".";
}

bool WriteAll(const std::string& path, const uint8_t* data, size_t size) {
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  if (fd < 0) return false;
  while (size > 0) {
    const ssize_t n = write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      close(fd);
      return false;
    }
    data += n;
    size -= static_cast<size_t>(n);
  }
  return close(fd) == 0;
}

void RemoveTempFiles() {
  if (g_path.empty()) return;
  // SQLite never creates these for a read-only connection; remove them
  // anyway so that a stale one cannot change how the next input is opened.
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) {
    unlink((g_path + suffix).c_str());
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  // The reader warns about every kind of damage; thousands of inputs per
  // second would drown libFuzzer's own output. The messages are still
  // formatted (that code is fuzzed too), only not printed.
  const char* verbose = std::getenv("GLOMAP_FUZZ_VERBOSE");
  g_verbose = verbose != nullptr && *verbose != '\0' && *verbose != '0';
  FLAGS_logtostderr = true;
  FLAGS_minloglevel = g_verbose ? google::GLOG_INFO : google::GLOG_FATAL;
  FLAGS_stderrthreshold = FLAGS_minloglevel;
  FLAGS_v = -1;
  g_path = TempDir() + "/glomap_database_reader_fuzzer_" +
           std::to_string(getpid()) + ".db";
  std::atexit(RemoveTempFiles);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  RemoveTempFiles();
  if (!WriteAll(g_path, data, size)) {
    // Not a finding of the reader: the machine's temp space is gone.
    std::fprintf(stderr, "database_reader_fuzzer: cannot write %s\n",
                 g_path.c_str());
    std::abort();
  }
  colmap::Reconstruction reconstruction;
  glomap::ViewGraph view_graph;
  const glomap::Status status = glomap::ReadDatabase(
      g_path, glomap::DatabaseReaderOptions(), &reconstruction, &view_graph);
  if (g_verbose) {
    std::fprintf(stderr, "database_reader_fuzzer: %zu bytes: %s%s\n", size,
                 status.ok() ? "OK" : "error: ", status.message().c_str());
  }
  RemoveTempFiles();
  return 0;
}
