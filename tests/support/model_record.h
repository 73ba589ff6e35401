// A model recorded as text (tests/data/recorded_models/), so that a test can
// check that a change which is meant to change no behaviour (a refactoring,
// a new option at its old default) gives the same model as before. The
// record holds what a user sees of a model: each camera's parameters, each
// registered image's pose, and the point and observation counts.
#pragma once

#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/util/status.h"

namespace glomap {
namespace testing {

// Writes `model` to `path` (one line per camera and per registered image,
// sorted by id and name; 17 significant digits, so reading it back loses
// nothing). `title` becomes the first, comment line.
Status WriteModelRecord(const colmap::Reconstruction& model,
                        const std::string& title, const std::string& path);

// How far a model may be from its record and still be "the same": the same
// machine and binary give identical numbers; another CPU or math library
// may differ in the last digits of a long chain of solves, far below these.
struct ModelRecordTolerances {
  // Camera centres, as a fraction of the largest distance between two
  // recorded centres.
  double max_center_difference_ratio = 1e-5;
  double max_rotation_difference_deg = 1e-4;
  // Camera parameters, relative to the recorded value (absolute below 1).
  double max_camera_param_difference = 1e-5;
  // Point and observation counts, relative: a point at a threshold may go
  // either way after a last-digit difference.
  double max_count_difference_ratio = 1e-3;
};

// Compares `model` with the record at `path`. Returns one line per
// difference beyond `tolerances` (the first 20), or one line if the record
// cannot be read; empty when the model is the same.
std::vector<std::string> CompareWithModelRecord(
    const colmap::Reconstruction& model, const std::string& path,
    const ModelRecordTolerances& tolerances = ModelRecordTolerances());

}  // namespace testing
}  // namespace glomap
