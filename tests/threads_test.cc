// GlobalMapper.num_threads (issue 14): the libraries under the pipeline start
// no threads of their own (their OpenMP regions run on the calling thread);
// with one thread the same seed gives the same model bit for bit, on a
// problem on which two threads would run positioning and every bundle
// adjustment on two; below the multi-thread threshold two threads give the
// model of one.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "base/reconstruction_manager.h"
#include "glomap/controllers/global_mapper_controller.h"
#include "glomap/util/ceres_threads.h"
#include "glomap/util/parallel_for.h"
#include "tests/support/synthetic_scene.h"
#include "tests/support/test_paths.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace glomap {
namespace {

#ifdef _OPENMP
// The team size of an OpenMP region that asks for `num_threads` threads, as
// CHOLMOD's loops ask for 4.
int OpenMpTeamSize(int num_threads) {
  int team_size = 0;
#pragma omp parallel num_threads(num_threads)
  {
#pragma omp single
    team_size = omp_get_num_threads();
  }
  return team_size;
}

TEST(LibraryThreads, OpenMpRegionsRunOnTheCallingThread) {
  const int team_size_before = OpenMpTeamSize(4);
  const int max_threads_before = omp_get_max_threads();
  {
    ScopedSerialOpenMp serial_openmp;
    EXPECT_EQ(OpenMpTeamSize(4), 1);
    EXPECT_EQ(omp_get_max_threads(), 1);
  }
  EXPECT_EQ(OpenMpTeamSize(4), team_size_before);
  EXPECT_EQ(omp_get_max_threads(), max_threads_before);
}

TEST(LibraryThreads, ParallelForThreadsRunOpenMpRegionsAlone) {
  for (const int num_threads : {1, 3}) {
    std::vector<int> team_sizes(12, 0);
    ParallelFor(num_threads, team_sizes.size(),
                [&](size_t i) { team_sizes[i] = OpenMpTeamSize(4); });
    for (size_t i = 0; i < team_sizes.size(); ++i) {
      EXPECT_EQ(team_sizes[i], 1) << num_threads << " threads, item " << i;
    }
  }
}
#endif

// What the pipeline returned, and the fewest observations the model had
// whenever it changed (after global positioning, after each bundle-adjustment
// round, after retriangulation, at the end).
struct ThreadsRun {
  Status status;
  std::vector<colmap::Reconstruction> models;
  GlobalMapperSummary summary;
  size_t min_num_observations = std::numeric_limits<size_t>::max();
};

// One run through the controller, the thread `colmap global_mapper` and the
// GUI run the pipeline on.
ThreadsRun RunController(const GlobalMapperOptions& options,
                         const std::string& database_path) {
  ThreadsRun run;
  colmap::ReconstructionManager manager;
  GlobalMapperController controller(options, database_path, &manager);
  // The working model is the manager's only one while the pipeline runs;
  // the last call, after it, sees the largest final model.
  controller.AddCallback(GlobalMapperController::MODEL_UPDATED_CALLBACK, [&]() {
    run.min_num_observations = std::min(
        run.min_num_observations, manager.Get(0).ComputeNumObservations());
  });
  controller.Start();
  controller.Wait();
  run.status = controller.RunStatus();
  run.summary = controller.Summary();
  for (size_t i = 0; i < manager.Size(); ++i) {
    run.models.push_back(manager.Get(i));
  }
  return run;
}

// Every camera's parameters, every registered image's pose and every point's
// position and track, compared exactly (==).
void ExpectBitIdentical(const colmap::Reconstruction& a,
                        const colmap::Reconstruction& b) {
  ASSERT_EQ(a.NumCameras(), b.NumCameras());
  for (const auto& [camera_id, camera] : a.Cameras()) {
    ASSERT_TRUE(b.ExistsCamera(camera_id)) << "camera " << camera_id;
    EXPECT_EQ(camera.ModelId(), b.Camera(camera_id).ModelId());
    EXPECT_EQ(camera.Params(), b.Camera(camera_id).Params())
        << "camera " << camera_id;
  }
  std::vector<colmap::image_t> image_ids = a.RegImageIds();
  std::vector<colmap::image_t> other_image_ids = b.RegImageIds();
  std::sort(image_ids.begin(), image_ids.end());
  std::sort(other_image_ids.begin(), other_image_ids.end());
  ASSERT_EQ(image_ids, other_image_ids);
  for (const colmap::image_t image_id : image_ids) {
    EXPECT_EQ(a.Image(image_id).Qvec(), b.Image(image_id).Qvec())
        << "image " << image_id;
    EXPECT_EQ(a.Image(image_id).Tvec(), b.Image(image_id).Tvec())
        << "image " << image_id;
  }
  ASSERT_EQ(a.NumPoints3D(), b.NumPoints3D());
  size_t num_different_points = 0;
  for (const auto& [point3D_id, point3D] : a.Points3D()) {
    if (!b.ExistsPoint3D(point3D_id)) {
      ++num_different_points;
      continue;
    }
    const colmap::Point3D& other = b.Point3D(point3D_id);
    bool same = point3D.XYZ() == other.XYZ() &&
                point3D.Track().Length() == other.Track().Length();
    for (size_t k = 0; same && k < point3D.Track().Length(); ++k) {
      same = point3D.Track().Element(k).image_id ==
                 other.Track().Element(k).image_id &&
             point3D.Track().Element(k).point2D_idx ==
                 other.Track().Element(k).point2D_idx;
    }
    if (!same) ++num_different_points;
  }
  EXPECT_EQ(num_different_points, 0u) << "of " << a.NumPoints3D() << " points";
}

// The threshold this test runs with, and why not the default: a scene above
// 150000 residual blocks (the 500-image survey of ceres_threads.h, 174k
// observations in positioning and BA) takes about 110 s of CPU per run here,
// so the scene is smaller (34k observations, about 10 s of CPU per run) and
// the threshold lower. The code path is the same (CeresNumThreads only
// compares the two), and the test checks that every Ceres solve of the run
// was above it.
constexpr int kTestMinResidualsPerCeresThread = 10000;

TEST(Threads, OneThreadSameSeedSameModelAboveTheMultiThreadThreshold) {
  const std::string dir = testing::CreateTestDir("threads_one_thread");
  SyntheticSceneOptions scene;
  // Above 150 images: bundle adjustment solves with a sparse Schur
  // complement (CHOLMOD), as rotation averaging does above 128 images.
  scene.num_images = 160;
  scene.layout = "grid";
  scene.pixel_noise_px = 1.0;
  scene.wrong_match_ratio = 0.1;
  scene.max_pairs_per_image = 10;
  scene.num_points3D = 4500;
  scene.prior_focal_length = false;
  scene.verification = "ground_truth";
  scene.random_seed = 3;
  colmap::Reconstruction truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, dir + "/database.db", &truth).ok());

  GlobalMapperOptions options;
  options.num_threads = 1;
  options.random_seed = 5;
  options.min_residuals_per_ceres_thread = kTestMinResidualsPerCeresThread;
  const ThreadsRun first = RunController(options, dir + "/database.db");
  ASSERT_TRUE(first.status.ok()) << first.status.message();
  const ThreadsRun second = RunController(options, dir + "/database.db");
  ASSERT_TRUE(second.status.ok()) << second.status.message();

  // The run was above the threshold: with two threads, global positioning
  // and every bundle adjustment (each has at least as many residual blocks
  // as the model has observations after it) would have run on two.
  ASSERT_EQ(first.summary.num_deregistered_images, 0u);
  ASSERT_EQ(first.summary.num_replaced_images, 0u);
  ASSERT_NE(first.min_num_observations, std::numeric_limits<size_t>::max());
  EXPECT_EQ(CeresNumThreads(2, first.min_num_observations,
                            kTestMinResidualsPerCeresThread),
            2)
      << first.min_num_observations << " observations";

  ASSERT_EQ(first.models.size(), second.models.size());
  ASSERT_FALSE(first.models.empty());
  for (size_t i = 0; i < first.models.size(); ++i) {
    SCOPED_TRACE("model " + std::to_string(i));
    ExpectBitIdentical(first.models[i], second.models[i]);
  }
}

// Below the threshold every Ceres solve runs on one thread whatever
// num_threads says, and the stages that run on several (relative poses, pose
// verification) give each item its own output slot and random seed: two
// threads give the model of one, bit for bit.
TEST(Threads, BelowTheThresholdTwoThreadsGiveTheModelOfOne) {
  const std::string dir = testing::CreateTestDir("threads_small_problem");
  SyntheticSceneOptions scene;
  scene.num_images = 40;
  scene.wrong_match_ratio = 0.1;
  scene.max_pairs_per_image = 10;
  scene.verification = "ground_truth";
  scene.random_seed = 4;
  colmap::Reconstruction truth;
  ASSERT_TRUE(WriteSyntheticScene(scene, dir + "/database.db", &truth).ok());
  // No solve can have more residual blocks than there are keypoints (one
  // per observation) or pairs (calibration).
  const size_t max_num_residual_blocks =
      std::max<size_t>(scene.num_images * scene.max_keypoints_per_image,
                       scene.num_images * (scene.num_images - 1) / 2);
  ASSERT_EQ(CeresNumThreads(2, max_num_residual_blocks,
                            kMinResidualBlocksPerCeresThread),
            1);

  GlobalMapperOptions options;
  options.num_threads = 1;
  const ThreadsRun one_thread = RunController(options, dir + "/database.db");
  ASSERT_TRUE(one_thread.status.ok()) << one_thread.status.message();
  options.num_threads = 2;
  const ThreadsRun two_threads = RunController(options, dir + "/database.db");
  ASSERT_TRUE(two_threads.status.ok()) << two_threads.status.message();

  ASSERT_EQ(one_thread.models.size(), two_threads.models.size());
  ASSERT_FALSE(one_thread.models.empty());
  for (size_t i = 0; i < one_thread.models.size(); ++i) {
    SCOPED_TRACE("model " + std::to_string(i));
    ExpectBitIdentical(one_thread.models[i], two_threads.models[i]);
  }
}

}  // namespace
}  // namespace glomap
