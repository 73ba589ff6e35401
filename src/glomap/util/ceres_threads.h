// Threads of the pipeline: a Ceres solve's, from the user's thread option and
// the size of the problem (every stage that runs Ceres), and those that the
// libraries under the solves would start on their own.
#pragma once

#include <dlfcn.h>

#include <algorithm>
#include <cstddef>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "util/threading.h"

namespace glomap {

// Ceres 2.1 shares the Schur complement between threads with one lock per
// cell, and every point's chunk of a bundle adjustment updates the cells of
// the shared intrinsics; on small problems the second thread brings nothing.
// Measured on this project's 2-core machine, same models either way:
// - KITTI_sequence_1 (51 images, 30k observations in the BA rounds, 85k in
//   the final BA): in three alternating runs each, one thread for every
//   Ceres solve took 19.0-24.2 s wall, two threads 20.0-22.0 s (this
//   machine's run-to-run spread), and two threads used more CPU;
// - a 500-image survey (290k observations): two threads took positioning
//   from 78.1 s to 69.7 s and BA from 45.4 s to 42.2 s, so larger problems
//   keep their threads.
// The default of GlobalMapper.min_residuals_per_ceres_thread (a field of
// every stage's options that runs Ceres, set from it by the global mapper),
// in residual blocks per thread.
constexpr int kMinResidualBlocksPerCeresThread = 150000;

// `num_threads` is the user's option (-1: all cores); a solve gets one more
// thread per `min_residual_blocks_per_thread` residual blocks (at least 1,
// see the options' Check), up to it.
inline int CeresNumThreads(int num_threads, size_t num_residual_blocks,
                           int min_residual_blocks_per_thread) {
  const int max_threads = colmap::GetEffectiveNumThreads(num_threads);
  const size_t by_size =
      1 + num_residual_blocks /
              static_cast<size_t>(std::max(1, min_residual_blocks_per_thread));
  return static_cast<int>(
      std::max<size_t>(1, std::min<size_t>(max_threads, by_size)));
}

// The pipeline's threads are Ceres' (CeresNumThreads) and ParallelFor's, both
// at most GlobalMapper.num_threads. The libraries under them would start
// more of their own, which no thread option of ours reaches:
// - CHOLMOD (SuiteSparse 5.12, Debian's build; Ceres' sparse Schur solves
//   and rotation averaging) runs its clear and copy loops in OpenMP teams of
//   a fixed 4 threads (a num_threads(4) clause, which neither
//   omp_set_num_threads nor the number of cores bounds): measured with
//   num_threads 1 on a 500-image survey, 3 OpenMP threads from the first
//   rotation averaging on;
// - Eigen, which our code and COLMAP's are compiled with OpenMP for, splits
//   large dense products over omp_get_max_threads() threads (measured on a
//   160-image survey: every OpenMP region of the run was CHOLMOD's);
// - OpenBLAS (its pthreads build), when it is the system BLAS (one of
//   Debian's libblas.so.3 alternatives), starts its threads when it is
//   loaded and splits CHOLMOD's dense blocks over them: measured with
//   num_threads 1 on a 160-image survey, 0.18 s of CPU on its thread, and
//   a model that differs from the serial one in the last digits.
// So library code runs on the thread that calls it: OpenMP regions that a
// pipeline thread enters have a team of one, and OpenBLAS one thread (its
// threads stay idle). CHOLMOD's loops give the same result on any number of
// threads (the same model, byte for byte, on the 500-image survey).

// OpenMP regions that the calling thread enters run on it alone (a team of
// one, whatever their num_threads clause) while this object lives; the
// thread's settings are restored on destruction. libgomp (GCC 12's,
// measured) keeps these settings per thread: every pipeline thread that may
// enter OpenMP code sets them (see ParallelFor).
class ScopedSerialOpenMp {
 public:
  ScopedSerialOpenMp() {
#ifdef _OPENMP
    max_active_levels_ = omp_get_max_active_levels();
    max_threads_ = omp_get_max_threads();
    SetSerialOpenMpOnThisThread();
#endif
  }
  ~ScopedSerialOpenMp() {
#ifdef _OPENMP
    omp_set_num_threads(max_threads_);
    omp_set_max_active_levels(max_active_levels_);
#endif
  }
  ScopedSerialOpenMp(const ScopedSerialOpenMp&) = delete;
  ScopedSerialOpenMp& operator=(const ScopedSerialOpenMp&) = delete;

  // The same, without restoring: for a thread that ends with its work.
  static void SetSerialOpenMpOnThisThread() {
#ifdef _OPENMP
    // No active parallel region: every team has one thread. Eigen asks
    // omp_get_max_threads() and then does not even open a region.
    omp_set_max_active_levels(0);
    omp_set_num_threads(1);
#endif
  }

 private:
  int max_active_levels_ = 1;
  int max_threads_ = 1;
};

// For the lifetime of a pipeline run, on the thread that runs it: OpenMP
// regions entered by this thread run serially (ScopedSerialOpenMp), and
// OpenBLAS, if it is the BLAS the process loaded, uses one thread (its
// setting is process-wide; restored on destruction). Debian's ATLAS and
// reference BLAS are serial; BLIS and MKL are not handled.
class ScopedLibraryThreads {
 public:
  ScopedLibraryThreads() {
    // Found in whichever library provides them, if any (no link dependency
    // on OpenBLAS).
    set_blas_threads_ = reinterpret_cast<void (*)(int)>(
        dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
    const auto get_blas_threads = reinterpret_cast<int (*)()>(
        dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
    if (set_blas_threads_ != nullptr && get_blas_threads != nullptr) {
      blas_threads_ = get_blas_threads();
      set_blas_threads_(1);
    } else {
      set_blas_threads_ = nullptr;
    }
  }
  ~ScopedLibraryThreads() {
    if (set_blas_threads_ != nullptr) set_blas_threads_(blas_threads_);
  }
  ScopedLibraryThreads(const ScopedLibraryThreads&) = delete;
  ScopedLibraryThreads& operator=(const ScopedLibraryThreads&) = delete;

 private:
  ScopedSerialOpenMp serial_openmp_;
  void (*set_blas_threads_)(int) = nullptr;
  int blas_threads_ = 1;
};

}  // namespace glomap
