// Lets a user's cancel stop a Ceres solve at the end of the current
// iteration (as COLMAP's BundleAdjustmentController does for pausing); used
// by every stage that runs Ceres.
#pragma once

#include <ceres/ceres.h>

#include "glomap/util/status.h"

namespace glomap {

class InterruptCallback : public ceres::IterationCallback {
 public:
  explicit InterruptCallback(const Interrupt& interrupt)
      : interrupt_(interrupt) {}

  ceres::CallbackReturnType operator()(
      const ceres::IterationSummary& /*summary*/) override {
    return interrupt_.IsStopped() ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                  : ceres::SOLVER_CONTINUE;
  }

 private:
  const Interrupt& interrupt_;
};

}  // namespace glomap
