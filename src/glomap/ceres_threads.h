// Threads of a Ceres solve, from the user's thread option and the size of the
// problem; used by every stage that runs Ceres.
#pragma once

#include <algorithm>
#include <cstddef>

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
// every stage's options that runs Ceres, set from it by the global mapper).
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

}  // namespace glomap
