// The position priors of one mapper run (issue 12), owned by one object from
// the database to the written models: preparing them in one metric frame,
// the prior term that global positioning, bundle adjustment and
// retriangulation use, accepting positioning's result, the recheck after
// bundle adjustment, the output frame, and the final georegistration. With
// priors off (or unusable) it is inert: Term() is null, the models are
// normalised, and GetGeoregistration() says "not georegistered".
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/priors/position_priors.h"
#include "glomap/priors/prior_alignment.h"
#include "glomap/util/status.h"

namespace glomap {

class MapperPriors {
 public:
  // Reads and validates the priors of `work`'s images (PreparePositionPriors)
  // and puts them in the frame the solves work in: the priors' mean (whole
  // metres) taken out, put back in the output. Off or unusable priors leave
  // the object inert; an error only for priors that the options ask for and
  // the database cannot give.
  Status Prepare(const PositionPriorOptions& options,
                 const colmap::Reconstruction& work);

  // The priors the solves use, or null without usable priors (or once
  // positioning could not fix the frame with them).
  const PositionPriorTerm* Term() const {
    return used_.empty() ? nullptr : &used_;
  }

  // The model is in the prior frame, in metres (positioning fixed it).
  bool georegistered() const { return georegistration_.georegistered; }

  // Takes global positioning's result: when `georegistered`, the model is
  // in the prior frame and `rejected_image_ids` (priors farther than the
  // threshold from their camera) are left out of every later solve; else
  // the priors are dropped and `work` is normalised, as without priors.
  // Returns the counts to add to the stage line ("" when not georegistered).
  std::string AcceptPositioning(
      bool georegistered, size_t num_priors_used,
      const std::vector<colmap::image_t>& rejected_image_ids,
      colmap::Reconstruction* work);

  // Judges every prior again on the adjusted model (positioning's solution
  // can still be bent where cameras are far from good priors; bundle
  // adjustment with the other priors straightens it): re-admits those now
  // within the threshold, rejects those beyond, unless the new choice would
  // not fix a similarity. Nothing when not georegistered.
  void RecheckAfterBundleAdjustment(const colmap::Reconstruction& work);

  // Notes the names of the rejected images (from `work`, before the models
  // are cut out of it).
  void NoteRejectedImageNames(const colmap::Reconstruction& work);

  // Puts an output model in its frame: the prior frame in metres (the
  // offset taken out for the solve put back), or normalised.
  void ToOutputFrame(colmap::Reconstruction* model) const;

  // Logs the final distances between cameras and priors and the priors'
  // noise as the models show it (warning when it is well above the stated
  // deviation), and sets the figures of GetGeoregistration(). Nothing when not
  // georegistered.
  void ReportOnModels(const std::vector<colmap::Reconstruction>& models);

  // What was done with the priors (georegistration.txt).
  const Georegistration& GetGeoregistration() const { return georegistration_; }

 private:
  // The priors the solves use (rejected ones left out).
  PositionPriorTerm used_;
  // Every usable prior, also the rejected ones (they are checked again).
  PositionPriorTerm all_;
  std::vector<colmap::image_t> rejected_image_ids_;
  Eigen::Vector3d frame_offset_ = Eigen::Vector3d::Zero();
  Georegistration georegistration_;
};

}  // namespace glomap
