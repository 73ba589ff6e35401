#include "glomap/estimators/retriangulation.h"

#include <algorithm>
#include <iostream>
#include <limits>
#include <unordered_set>
#include <vector>

#include "base/correspondence_graph.h"
#include "base/database_cache.h"
#include "glomap/estimators/point_refinement.h"
#include "glomap/processors/track_filters.h"
#include "glomap/util/options_check.h"
#include "glomap/util/return_freed_memory.h"
#include "sfm/incremental_triangulator.h"
#include "util/logging.h"
#include "util/threading.h"
#include "util/timer.h"

namespace glomap {
namespace {

colmap::IncrementalTriangulator::Options TriangulatorOptions(
    const RetriangulationOptions& options) {
  colmap::IncrementalTriangulator::Options tri_options;
  tri_options.complete_max_reproj_error = options.complete_max_reproj_error_px;
  tri_options.merge_max_reproj_error = options.merge_max_reproj_error_px;
  tri_options.create_max_angle_error = options.create_max_angle_error_deg;
  tri_options.continue_max_angle_error = options.continue_max_angle_error_deg;
  tri_options.min_angle = options.min_angle_deg;
  // COLMAP's triangulator skips every image whose camera looks bogus (focal
  // outside [0.1, 10] x the image size, or an extra parameter above 1): the
  // incremental mapper's guard against building on a failed registration.
  // Here the cameras come from bundle adjustment over all views, and
  // skipping them leaves no point at all, which failed the whole run
  // (dino-363: bundle adjustment of a model built with a 4x wrong focal
  // gave k1 = 1.54, and "Bundle adjustment needs at least two registered
  // images with 3D points"). Long lenses exceed the focal ratio of 10 too.
  // The model's cameras are therefore used as they are.
  tri_options.min_focal_length_ratio = 0;
  tri_options.max_focal_length_ratio = std::numeric_limits<double>::max();
  tri_options.max_extra_param = std::numeric_limits<double>::max();
  return tri_options;
}

// Same as COLMAP's CompleteAndMergeTracks in exe/sfm.cc; returns the number
// of observations that changed.
size_t CompleteAndMergeTracks(
    const colmap::IncrementalTriangulator::Options& tri_options,
    colmap::IncrementalTriangulator* triangulator) {
  const size_t num_completed = triangulator->CompleteAllTracks(tri_options);
  const size_t num_merged = triangulator->MergeAllTracks(tri_options);
  return num_completed + num_merged;
}

}  // namespace

Status RetriangulationOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.AtLeast("min_num_matches", min_num_matches, 1);
  check.GreaterThan("complete_max_reproj_error_px",
                    complete_max_reproj_error_px, 0);
  check.GreaterThan("merge_max_reproj_error_px", merge_max_reproj_error_px, 0);
  check.GreaterThan("create_max_angle_error_deg", create_max_angle_error_deg,
                    0);
  check.GreaterThan("continue_max_angle_error_deg",
                    continue_max_angle_error_deg, 0);
  check.AtLeast("min_angle_deg", min_angle_deg, 0);
  check.AtLeast("max_refinements", max_refinements, 0);
  check.AtLeast("max_refinement_change", max_refinement_change, 0);
  check.AtLeast("max_num_structure_iterations", max_num_structure_iterations,
                1);
  check.GreaterThan("filter_max_reproj_error_px", filter_max_reproj_error_px,
                    0);
  check.AtLeast("filter_min_tri_angle_deg", filter_min_tri_angle_deg, 0);
  check.AtLeast("final_ba_max_num_iterations", final_ba_max_num_iterations, 1);
  check.AtLeast("final_ba_loss_scale_px", final_ba_loss_scale_px, 0);
  check.AtLeast("final_ba_max_num_observations", final_ba_max_num_observations,
                0);
  check.Add(bundle_adjustment.Check(prefix + "bundle_adjustment."));
  return check.status();
}

namespace {

// Points triangulated and refined with the poses of `reconstruction` fixed,
// and what it took.
struct TriangulatedPoints {
  struct Point {
    Eigen::Vector3d xyz;
    colmap::Track track;
    Eigen::Vector3ub color;
  };
  std::vector<Point> points;  // In the order of their ids in the triangulation.
  size_t num_pairs = 0;
  size_t num_triangulated = 0;  // Before the refinement loop.
};

// Triangulates the matches of the view graph between the images
// `registered_ids` of `reconstruction` (sorted) and refines the points as
// COLMAP's point_triangulator does. The correspondence graph and the
// triangulation's own model are freed on return: only the points are
// handed back (their tracks moved, not copied).
Status TriangulateWithFixedPoses(
    const RetriangulationOptions& options, const ViewGraph& view_graph,
    const colmap::Reconstruction& reconstruction,
    const std::vector<colmap::image_t>& registered_ids,
    const Interrupt& interrupt, TriangulatedPoints* result) {
  const std::unordered_set<colmap::image_t> registered(registered_ids.begin(),
                                                       registered_ids.end());

  // The triangulator needs a CorrespondenceGraph, and COLMAP only accepts one
  // together with per-pair statistics that Reconstruction::Load(DatabaseCache)
  // fills (SetObservationAsTriangulated CHECKs against them). We therefore
  // fill the graph of a DatabaseCache in memory instead of loading it from
  // the database (which would open it read-write and use other pairs). The
  // cache holds no image: the graph needs only the number of keypoints of
  // each image, and the triangulation's images are made once, in `work`.
  colmap::DatabaseCache cache;
  colmap::CorrespondenceGraph& graph = MutableCorrespondenceGraph(&cache);
  for (const colmap::image_t image_id : registered_ids) {
    graph.AddImage(image_id, reconstruction.Image(image_id).NumPoints2D());
  }
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if (pair.matches.size() < static_cast<size_t>(options.min_num_matches) ||
        (options.use_only_valid_pairs && !pair.is_valid) ||
        registered.count(pair.image_id1) == 0 ||
        registered.count(pair.image_id2) == 0) {
      continue;
    }
    const colmap::FeatureMatches matches = CleanMatches(
        pair.matches, reconstruction.Image(pair.image_id1).NumPoints2D(),
        reconstruction.Image(pair.image_id2).NumPoints2D());
    graph.AddCorrespondences(pair.image_id1, pair.image_id2, matches);
    ++result->num_pairs;
  }
  graph.Finalize();  // Drops images without correspondences from the graph.
  if (graph.NumImages() < 2) {
    return Status::Error(
        "Retriangulation: no image pair with enough matches between "
        "registered images.");
  }

  // Declared after `cache`, so it is destroyed first (it points to the
  // graph). Load takes the pair statistics; the images of the graph come
  // from `reconstruction`, with their keypoints and poses but no points.
  colmap::Reconstruction work;
  work.Load(cache);
  std::vector<colmap::image_t> triangulated_ids;
  for (const colmap::image_t image_id : registered_ids) {
    if (!graph.ExistsImage(image_id)) continue;
    const colmap::Image& source = reconstruction.Image(image_id);
    if (!work.ExistsCamera(source.CameraId())) {
      work.AddCamera(reconstruction.Camera(source.CameraId()));
    }
    colmap::Image image = KeypointImage(source);
    image.SetQvec(source.Qvec());
    image.SetTvec(source.Tvec());
    image.SetNumObservations(graph.NumObservationsForImage(image_id));
    image.SetNumCorrespondences(graph.NumCorrespondencesForImage(image_id));
    work.AddImage(std::move(image));
    work.RegisterImage(image_id);
    triangulated_ids.push_back(image_id);
  }
  work.SetUp(&graph);

  colmap::IncrementalTriangulator::Options tri_options =
      TriangulatorOptions(options);
  // COLMAP leaves features seen in only two images untriangulated; in a
  // two-view model (min_model_size 2) there are no others.
  tri_options.ignore_two_view_tracks = triangulated_ids.size() > 2;
  if (!tri_options.Check()) {
    return Status::Error("Invalid triangulation options.");
  }
  colmap::IncrementalTriangulator triangulator(&graph, &work);
  for (const colmap::image_t image_id : triangulated_ids) {
    if (interrupt.IsStopped()) return Status::Cancelled();
    triangulator.TriangulateImage(tri_options, image_id);
  }
  CompleteAndMergeTracks(tri_options, &triangulator);
  result->num_triangulated = work.NumPoints3D();

  // Structure-only refinement, as COLMAP's point_triangulator: poses and
  // intrinsics stay fixed, so each point is refined alone
  // (RefinePointsWithFixedPoses).
  PointRefinementOptions refinement_options;
  refinement_options.max_num_iterations = options.max_num_structure_iterations;
  refinement_options.num_threads = options.bundle_adjustment.num_threads;
  for (int i = 0; i < options.max_refinements; ++i) {
    if (interrupt.IsStopped()) return Status::Cancelled();
    work.FilterObservationsWithNegativeDepth();
    const size_t num_observations = work.ComputeNumObservations();
    if (num_observations == 0) break;
    PointRefinementSummary summary;
    const Status refinement = RefinePointsWithFixedPoses(
        refinement_options, /*point3D_ids=*/{}, &work, interrupt, &summary);
    if (!refinement.ok()) return refinement;
    VLOG(3) << "Retriangulation: structure-only refinement of "
            << summary.num_points << " points (" << summary.num_observations
            << " observations), cost " << summary.initial_cost << " -> "
            << summary.final_cost << " px^2";
    size_t num_changed = CompleteAndMergeTracks(tri_options, &triangulator);
    num_changed += work.FilterAllPoints3D(options.filter_max_reproj_error_px,
                                          options.filter_min_tri_angle_deg);
    if (static_cast<double>(num_changed) / num_observations <
        options.max_refinement_change) {
      break;
    }
  }

  // The tracks are moved out: `work` is dropped on return.
  const std::vector<colmap::point3D_t> point3D_ids = SortedPoint3DIds(work);
  result->points.reserve(point3D_ids.size());
  for (const colmap::point3D_t point3D_id : point3D_ids) {
    colmap::Point3D& point3D = work.Point3D(point3D_id);
    result->points.push_back(
        {point3D.XYZ(), std::move(point3D.Track()), point3D.Color()});
  }
  return Status::Ok();
}

}  // namespace

Status Retriangulate(const RetriangulationOptions& options,
                     const ViewGraph& view_graph,
                     colmap::Reconstruction* reconstruction,
                     const Interrupt& interrupt,
                     const PositionPriorTerm* priors) {
  if (const Status check = options.Check(); !check.ok()) {
    return Status::Error("Invalid retriangulation options: " + check.message());
  }
  if (reconstruction == nullptr) {
    return Status::Error("No reconstruction to retriangulate.");
  }
  colmap::Timer timer;
  timer.Start();
  std::vector<colmap::image_t> registered_ids = reconstruction->RegImageIds();
  std::sort(registered_ids.begin(), registered_ids.end());
  if (registered_ids.size() < 2) {
    return Status::Error(
        "Retriangulation needs at least two registered images.");
  }
  TriangulatedPoints triangulated;
  const Status triangulation =
      TriangulateWithFixedPoses(options, view_graph, *reconstruction,
                                registered_ids, interrupt, &triangulated);
  if (!triangulation.ok()) return triangulation;

  // Replace the points of `reconstruction` by the new ones. Images share ids
  // and Points2D with the triangulation's, so the tracks carry over
  // unchanged.
  const size_t num_old_points3D = DeleteAllPoints3D(reconstruction);
  for (TriangulatedPoints::Point& point : triangulated.points) {
    reconstruction->AddPoint3D(point.xyz, std::move(point.track), point.color);
  }
  triangulated.points = std::vector<TriangulatedPoints::Point>();
  // The correspondence graph and the triangulation's images are freed:
  // their pages go back to the system before bundle adjustment allocates.
  ReturnFreedMemory();
  VLOG(3) << "Retriangulation: " << triangulated.num_pairs << " pairs, "
          << triangulated.num_triangulated << " points triangulated, "
          << reconstruction->NumPoints3D() << " after refinement ("
          << num_old_points3D << " before), " << timer.ElapsedSeconds() << " s";

  if (options.run_bundle_adjustment) {
    GlobalBundleAdjustmentOptions final_ba = options.bundle_adjustment;
    final_ba.max_num_solve_observations = options.final_ba_max_num_observations;
    const Status status =
        RunGlobalBundleAdjustment(final_ba, reconstruction, interrupt,
                                  /*on_round_done=*/{}, priors);
    if (!status.ok()) return status;
  }
  UpdatePointErrors(reconstruction);
  return Status::Ok();
}

}  // namespace glomap
