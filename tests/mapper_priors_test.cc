// The position priors of one mapper run (MapperPriors): inert without
// priors, the solve's frame offset taken out and put back, what accepting
// positioning and the recheck after bundle adjustment do with rejected
// priors, and the final report. Reconstructions built by hand, metric
// priors far from the origin (as projected coordinates are).
#include "glomap/priors/mapper_priors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "base/pose.h"
#include "base/reconstruction.h"

namespace glomap {
namespace {

// A projected frame's coordinates: millions of metres.
const Eigen::Vector3d kFarOrigin(2.6e6, 1.2e6, 410.3);

// Eight registered images on a 3 x 3 grid's border (not collinear), each at
// its prior (plus `shift_of_last` for the last image) minus `offset`, as
// global positioning leaves a model in the solve's frame; priors in the
// database's frame (offset included). With use_priors false no image has a
// prior.
colmap::Reconstruction MakeModel(bool use_priors, const Eigen::Vector3d& offset,
                                 const Eigen::Vector3d& shift_of_last) {
  colmap::Reconstruction model;
  colmap::Camera camera;
  camera.SetCameraId(1);
  camera.InitializeWithName("SIMPLE_PINHOLE", 500, 640, 480);
  model.AddCamera(camera);
  const std::vector<Eigen::Vector2d> grid = {
      {0, 0}, {10, 0}, {20, 0}, {20, 10}, {20, 20}, {10, 20}, {0, 20}, {0, 10}};
  for (size_t i = 0; i < grid.size(); ++i) {
    colmap::Image image;
    image.SetImageId(i + 1);
    image.SetName("image" + std::to_string(i + 1) + ".png");
    image.SetCameraId(1);
    const Eigen::Vector3d prior =
        kFarOrigin + Eigen::Vector3d(grid[i].x(), grid[i].y(), 0);
    image.SetTvecPrior(use_priors
                           ? prior
                           : Eigen::Vector3d::Constant(
                                 std::numeric_limits<double>::quiet_NaN()));
    image.SetQvec(colmap::ComposeIdentityQuaternion());
    Eigen::Vector3d center = prior - offset;
    if (i + 1 == grid.size()) center += shift_of_last;
    image.SetTvec(-center);  // identity rotation: t = -c
    model.AddImage(image);
    model.RegisterImage(i + 1);
  }
  return model;
}

PositionPriorOptions UsePriors() {
  PositionPriorOptions options;
  options.use_position_priors = true;
  options.prior_position_std_m = 1;
  options.prior_max_error_std = 5;
  return options;
}

TEST(MapperPriors, InertWithoutPriors) {
  colmap::Reconstruction model =
      MakeModel(false, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  MapperPriors priors;
  ASSERT_TRUE(priors.Prepare(UsePriors(), model).ok());
  EXPECT_EQ(priors.Term(), nullptr);
  EXPECT_FALSE(priors.georegistered());
  EXPECT_EQ(priors.AcceptPositioning(false, 0, {}, &model), "");
  priors.RecheckAfterBundleAdjustment(model);
  priors.NoteRejectedImageNames(model);
  // The output frame is the normalised one, as without priors.
  priors.ToOutputFrame(&model);
  EXPECT_LT(model.Image(1).ProjectionCenter().norm(), 20);
  priors.ReportOnModels({model});
  EXPECT_FALSE(priors.GetGeoregistration().georegistered);
  EXPECT_EQ(priors.GetGeoregistration().num_priors_used, 0u);
}

TEST(MapperPriors, SolvesNearTheOriginAndWritesInThePriorFrame) {
  // What Prepare takes out (the priors' mean in whole metres).
  const Eigen::Vector3d offset =
      (kFarOrigin + Eigen::Vector3d(10, 10, 0)).array().round().matrix();
  colmap::Reconstruction model =
      MakeModel(true, offset, Eigen::Vector3d::Zero());
  MapperPriors priors;
  ASSERT_TRUE(priors.Prepare(UsePriors(), model).ok());
  ASSERT_NE(priors.Term(), nullptr);
  EXPECT_EQ(priors.Term()->center_in_frame.size(), 8u);
  // The solve's frame is centred: every prior within the grid's size.
  for (const auto& [image_id, center] : priors.Term()->center_in_frame) {
    EXPECT_LT(center.norm(), 20) << image_id;
  }
  EXPECT_EQ(priors.AcceptPositioning(true, 8, {}, &model),
            "priors_used=8, priors_rejected=0");
  EXPECT_TRUE(priors.georegistered());
  priors.NoteRejectedImageNames(model);
  priors.ToOutputFrame(&model);
  // Back in the database's frame, exactly at the priors.
  for (const colmap::image_t image_id : model.RegImageIds()) {
    EXPECT_LT((model.Image(image_id).ProjectionCenter() -
               model.Image(image_id).TvecPrior())
                  .norm(),
              1e-6)
        << image_id;
  }
  priors.ReportOnModels({model});
  EXPECT_TRUE(priors.GetGeoregistration().georegistered);
  EXPECT_EQ(priors.GetGeoregistration().num_priors_used, 8u);
  EXPECT_TRUE(priors.GetGeoregistration().rejected_prior_image_names.empty());
}

TEST(MapperPriors, PositioningThatCannotFixTheFrameDropsThePriors) {
  colmap::Reconstruction model =
      MakeModel(true, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  MapperPriors priors;
  ASSERT_TRUE(priors.Prepare(UsePriors(), model).ok());
  ASSERT_NE(priors.Term(), nullptr);
  EXPECT_EQ(priors.AcceptPositioning(false, 0, {}, &model), "");
  EXPECT_EQ(priors.Term(), nullptr);  // later solves run free
  EXPECT_FALSE(priors.georegistered());
  // Normalised as without priors (was millions of metres away).
  EXPECT_LT(model.Image(1).ProjectionCenter().norm(), 20);
}

TEST(MapperPriors, RejectedPriorIsLeftOutAndReadmittedWhenItFitsAgain) {
  const Eigen::Vector3d offset =
      (kFarOrigin + Eigen::Vector3d(10, 10, 0)).array().round().matrix();
  // The last image 30 m from its prior (beyond 5 x 1 m): positioning
  // rejected it.
  colmap::Reconstruction positioned =
      MakeModel(true, offset, Eigen::Vector3d(0, 0, 30));
  MapperPriors priors;
  ASSERT_TRUE(priors.Prepare(UsePriors(), positioned).ok());
  EXPECT_EQ(priors.AcceptPositioning(true, 7, {8}, &positioned),
            "priors_used=7, priors_rejected=1");
  ASSERT_NE(priors.Term(), nullptr);
  EXPECT_EQ(priors.Term()->center_in_frame.count(8), 0u);
  EXPECT_EQ(priors.Term()->center_in_frame.size(), 7u);

  // Still far after bundle adjustment: stays rejected.
  priors.RecheckAfterBundleAdjustment(positioned);
  EXPECT_EQ(priors.Term()->center_in_frame.count(8), 0u);

  // Bundle adjustment moved the camera to its prior: re-admitted.
  const colmap::Reconstruction adjusted =
      MakeModel(true, offset, Eigen::Vector3d::Zero());
  priors.RecheckAfterBundleAdjustment(adjusted);
  EXPECT_EQ(priors.Term()->center_in_frame.count(8), 1u);
  priors.NoteRejectedImageNames(adjusted);
  EXPECT_TRUE(priors.GetGeoregistration().rejected_prior_image_names.empty());
}

TEST(MapperPriors, RejectedImagesAreNamedInTheGeoregistration) {
  const Eigen::Vector3d offset =
      (kFarOrigin + Eigen::Vector3d(10, 10, 0)).array().round().matrix();
  colmap::Reconstruction model =
      MakeModel(true, offset, Eigen::Vector3d(0, 0, 30));
  MapperPriors priors;
  ASSERT_TRUE(priors.Prepare(UsePriors(), model).ok());
  priors.AcceptPositioning(true, 7, {8}, &model);
  priors.NoteRejectedImageNames(model);
  priors.ToOutputFrame(&model);
  priors.ReportOnModels({model});
  const Georegistration& georegistration = priors.GetGeoregistration();
  ASSERT_EQ(georegistration.rejected_prior_image_names.size(), 1u);
  EXPECT_EQ(georegistration.rejected_prior_image_names[0], "image8.png");
  // The priors in use (7) are counted on the final models.
  EXPECT_EQ(georegistration.num_priors_used, 7u);
}

}  // namespace
}  // namespace glomap
