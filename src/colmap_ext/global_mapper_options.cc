#include "colmap_ext/global_mapper_options.h"

#include <algorithm>
#include <boost/property_tree/ini_parser.hpp>
#include <boost/property_tree/ptree.hpp>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <type_traits>

#include "util/logging.h"
#include "util/option_manager.h"

namespace glomap {
namespace {

using Tier = GlobalMapperOptionTier;

class TableBuilder {
 public:
  explicit TableBuilder(std::vector<GlobalMapperOptionEntry>* table)
      : table_(table) {}

  void Group(const std::string& group) { group_ = group; }

  // An option a user tunes: its help ends with its unit and range in
  // brackets ("[deg, > 0]", "[0 or 1]").
  template <typename T>
  void Basic(const std::string& key, T* value, const std::string& help) {
    table_->push_back({group_, key, value, help, Tier::kBasic});
  }
  // A stage detail.
  template <typename T>
  void Advanced(const std::string& key, T* value, const std::string& help) {
    table_->push_back({group_, key, value, help, Tier::kAdvanced});
  }

 private:
  std::vector<GlobalMapperOptionEntry>* table_;
  std::string group_;
};

}  // namespace

std::vector<GlobalMapperOptionEntry> GlobalMapperOptionTable(
    GlobalMapperOptions* o) {
  std::vector<GlobalMapperOptionEntry> table;
  TableBuilder b(&table);

  b.Group("General");
  b.Basic("min_num_matches", &o->database.min_num_matches,
          "Pairs with fewer verified matches are ignored [matches, >= 0]");
  b.Advanced("ignore_watermarks", &o->database.ignore_watermarks,
             "Ignore pairs the matcher flagged as watermark");
  b.Basic("random_seed", &o->random_seed,
          "Seed of every random choice: same input and seed, same model [any "
          "integer]");
  b.Basic("num_threads", &o->num_threads,
          "Most threads any stage computes on at a time: relative poses, "
          "calibration, positioning, pose verification, bundle adjustment, "
          "retriangulation; colours are read on one. Libraries (CHOLMOD, "
          "BLAS, Eigen) start no threads of their own. With 1, the same input "
          "and seed give the same model bit for bit [threads; -1: all cores, "
          "or >= 1]");
  b.Advanced(
      "min_residuals_per_ceres_thread", &o->min_residuals_per_ceres_thread,
      "Small-problem rule of every Ceres solve (calibration, positioning, "
      "bundle adjustment, retriangulation): one thread per this many "
      "residual blocks (about one per observation), up to num_threads, so "
      "that smaller problems solve on one thread [residual blocks per "
      "thread, >= 1]");
  b.Basic("min_model_size", &o->min_model_size,
          "Camera clusters with fewer images are not written (a two-image "
          "project needs 2) [images, >= 2]");
  b.Basic("merge_identical_cameras", &o->merge_identical_cameras,
          "Cameras with identical focal prior flag, model, size and "
          "parameters (one camera per image, as feature_extractor writes them "
          "by default) are calibrated and refined as one camera, unless "
          "bundle adjustment finds that they fit clearly better apart; every "
          "image keeps its own camera in the output [0 or 1]");
  b.Basic("skip_view_graph_calibration", &o->skip_view_graph_calibration,
          "Keep the database's focal lengths [0 or 1]");
  b.Basic("skip_bundle_adjustment", &o->skip_bundle_adjustment,
          "Skip the global bundle-adjustment rounds [0 or 1]");
  b.Basic("skip_retriangulation", &o->skip_retriangulation,
          "Skip retriangulation [0 or 1]");
  b.Basic("skip_clustering", &o->skip_clustering,
          "Write all registered images as one model [0 or 1]");
  b.Basic("skip_pose_verification", &o->skip_pose_verification,
          "Do not check the camera poses against the structure (not "
          "recommended: a wrongly placed camera then goes unnoticed) [0 or "
          "1]");
  b.Basic("init_positions_from_pairs", &o->init_positions_from_pairs,
          "Start global positioning from camera centres fitted to the pairs' "
          "translation directions instead of random ones (keeps long streets "
          "in one model; see gp_random_start_unless_converged) [0 or 1]");

  b.Group("Position priors");
  auto& pp = o->position_priors;
  b.Basic("use_position_priors", &pp.use_position_priors,
          "Solve with the images' position priors (images.prior_tx/ty/tz: GPS "
          "or known positions): the model comes out in metres in their frame "
          "(georegistration.txt beside it) [0 or 1]");
  b.Basic("prior_is_gps", &pp.prior_is_gps,
          "The priors are latitude, longitude [deg] and altitude [m] (WGS84), "
          "as COLMAP's feature extractor stores EXIF GPS; solved in east-"
          "north-up metres around the first image's prior. Off: metric "
          "positions [m] [0 or 1]");
  b.Basic("prior_use_ecef", &pp.prior_use_ecef,
          "With prior_is_gps: solve in earth-centred, earth-fixed metres "
          "instead of east-north-up [0 or 1]");
  b.Basic("prior_position_std_m", &pp.prior_position_std_m,
          "Standard deviation of a prior, each axis [m, > 0]");
  b.Basic("prior_loss_scale", &pp.prior_loss_scale,
          "Cauchy loss scale of a prior's error: farther off, it counts less "
          "and less [standard deviations, > 0]");
  b.Basic("prior_max_error_std", &pp.prior_max_error_std,
          "After global positioning, priors farther from their camera are "
          "rejected and named in the log [standard deviations, > 0]");

  b.Group("View graph calibration");
  auto& vgc = o->view_graph_calibration;
  b.Advanced("vgc_calibrate_identical_cameras_as_one",
             &vgc.calibrate_identical_cameras_as_one,
             "Cameras without a focal prior with identical model, size and "
             "parameters (one camera per image, as feature_extractor writes "
             "them) get one focal length in view-graph calibration; bundle "
             "adjustment still refines each");
  b.Advanced("vgc_min_focal_ratio", &vgc.min_focal_ratio,
             "Reject a new focal length below this ratio of the old one");
  b.Advanced("vgc_max_focal_ratio", &vgc.max_focal_ratio,
             "Reject a new focal length above this ratio of the old one");
  b.Advanced("vgc_max_two_view_error", &vgc.max_two_view_error,
             "Pairs whose focal residual exceeds this are rejected");
  b.Advanced("vgc_loss_scale", &vgc.loss_scale, "Cauchy loss scale");
  b.Advanced("vgc_coarse_loss_scale", &vgc.coarse_loss_scale,
             "Cauchy loss scale of the first solve (at least vgc_loss_scale)");
  b.Advanced("vgc_max_num_iterations", &vgc.max_num_iterations,
             "Maximum solver iterations");
  b.Basic("vgc_multi_view_num_images", &vgc.multi_view_num_images,
          "Images of the small incremental reconstruction that calibrates "
          "focal lengths the fundamental matrices miss (orbits, turntables) "
          "[images, >= 0; 0: off]");
  b.Advanced("vgc_multi_view_min_rotation_bias_deg",
             &vgc.multi_view_min_rotation_bias_deg,
             "Use its focal lengths only where they change the relative "
             "rotations by at least this much in the median [deg]");
  b.Advanced("vgc_multi_view_min_num_images_per_camera",
             &vgc.multi_view_min_num_images_per_camera,
             "A camera's focal length is taken from the small reconstruction "
             "only if this many of its images are in it");

  b.Group("Relative poses");
  auto& rp = o->relative_pose;
  b.Advanced("rp_use_stored_geometry", &rp.use_stored_geometry,
             "Start each pair from the database's two-view geometry (RANSAC "
             "only where it fails or is missing)");
  b.Basic("rp_max_epipolar_error_px", &rp.max_epipolar_error_px,
          "RANSAC threshold of the essential matrix [px, > 0]");
  b.Advanced("rp_max_epipolar_error_E_px", &rp.max_epipolar_error_E_px,
             "Inlier threshold of calibrated pairs [px]");
  b.Advanced("rp_max_epipolar_error_F_px", &rp.max_epipolar_error_F_px,
             "Inlier threshold of uncalibrated pairs [px]");
  b.Advanced("rp_max_epipolar_error_H_px", &rp.max_epipolar_error_H_px,
             "Inlier threshold of planar or panoramic pairs [px]");
  b.Advanced("rp_min_epipole_angle_deg", &rp.min_epipole_angle_deg,
             "Matches closer to the epipole are not inliers [deg]");
  b.Basic("rp_min_num_inliers", &rp.min_num_inliers,
          "Pairs with fewer inliers are rejected [matches, >= 0]");
  b.Basic("rp_min_inlier_ratio", &rp.min_inlier_ratio,
          "Pairs with a lower inlier ratio are rejected [0 to 1]");

  b.Group("Rotation averaging");
  auto& ra = o->rotation_averaging;
  b.Advanced("ra_max_num_l1_iterations", &ra.max_num_l1_iterations,
             "Maximum L1 iterations");
  b.Advanced("ra_max_num_irls_iterations", &ra.max_num_irls_iterations,
             "Maximum IRLS iterations");
  b.Advanced("ra_irls_loss_parameter_sigma_deg",
             &ra.irls_loss_parameter_sigma_deg, "Geman-McClure scale [deg]");
  b.Basic("ra_max_rotation_error_deg", &ra.max_rotation_error_deg,
          "Pairs disagreeing with the global rotations by more are rejected "
          "[deg, > 0]");
  b.Basic("ra_num_rounds", &ra.num_rounds,
          "Solve, reject, solve again: number of solves [solves, >= 1]");
  b.Advanced("ra_use_triangle_support_in_tree",
             &ra.use_triangle_support_in_tree,
             "Start from a spanning tree of pairs that close consistent "
             "triangles");

  b.Group("Tracks");
  auto& tr = o->tracks;
  b.Advanced("track_max_intra_image_distance_px",
             &tr.max_intra_image_distance_px,
             "Tracks with two observations farther apart in one image are "
             "dropped [px]");
  b.Basic("track_min_num_views_per_track", &tr.min_num_views_per_track,
          "Minimum images per track [images, >= 2]");
  b.Advanced("track_max_num_views_per_track", &tr.max_num_views_per_track,
             "Maximum images per track (at least "
             "track_min_num_views_per_track)");
  b.Basic("track_max_num_tracks", &tr.max_num_tracks,
          "Maximum tracks [tracks, >= 0]");
  b.Basic("track_min_num_tracks_per_view", &tr.min_num_tracks_per_view,
          "Keep the longest tracks until every image has this many [tracks; "
          "-1: all tracks, or >= 1]");

  b.Group("Position initialization");
  auto& pi = o->position_initialization;
  b.Advanced("pi_loss_scale", &pi.loss_scale,
             "Huber loss scale on the pairs' translation directions");
  b.Advanced("pi_max_num_iterations", &pi.max_num_iterations,
             "Maximum solver iterations");

  b.Group("Global positioning");
  auto& gp = o->global_positioning;
  b.Advanced("gp_loss_scale", &gp.loss_scale, "Huber loss scale");
  b.Basic("gp_max_num_iterations", &gp.max_num_iterations,
          "Maximum solver iterations [iterations, >= 0]");
  b.Advanced("gp_optimize_positions", &gp.optimize_positions,
             "Optimize camera positions");
  b.Advanced("gp_optimize_points", &gp.optimize_points, "Optimize points");
  b.Advanced("gp_optimize_scales", &gp.optimize_scales, "Optimize ray scales");
  b.Advanced("gp_project_out_scales", &gp.project_out_scales,
             "Solve for centres and points only, each ray scale at its best "
             "value for them (variable projection); 0: the scales are "
             "unknowns of the solve");
  b.Advanced("gp_random_start_unless_converged",
             &gp.random_start_unless_converged,
             "With init_positions_from_pairs: if that start does not "
             "converge, also solve from the random start and keep the lower "
             "cost");
  b.Advanced("gp_random_start_max_num_images", &gp.random_start_max_num_images,
             "Up to this many images, solve the random start also when the "
             "start from the pairs converges");
  b.Advanced("gp_random_start_check_iterations",
             &gp.random_start_check_iterations,
             "That random solve is stopped after this many iterations if its "
             "cost is still above the other start's final cost (0: never)");
  b.Advanced("gp_uncalibrated_weight", &gp.uncalibrated_weight,
             "Weight of cameras without a focal prior");
  b.Basic("gp_max_angular_error_deg", &gp.max_angular_error_deg,
          "Observations with a larger angular error are removed [deg, > 0]");
  b.Advanced("gp_uncalibrated_angular_error_factor",
             &gp.uncalibrated_angular_error_factor,
             "For cameras without a focal prior, the angular-error limit is "
             "this multiple of gp_max_angular_error_deg");
  b.Basic("gp_min_tri_angle_deg", &gp.min_tri_angle_deg,
          "Points with a smaller triangulation angle are removed [deg, >= 0]");
  b.Advanced("gp_min_inlier_observation_ratio",
             &gp.min_inlier_observation_ratio,
             "Fail if fewer observations survive filtering");
  b.Advanced("gp_prior_max_num_iterations", &gp.prior_max_num_iterations,
             "With position priors: iterations of the second solve, in the "
             "prior frame with the prior term");

  b.Group("Pose verification");
  auto& pv = o->pose_verification;
  b.Basic("pv_max_reproj_error_px", &pv.max_reproj_error_px,
          "Inlier threshold of the check before the output [px, > 0]");
  b.Advanced("pv_positioning_max_reproj_error_px",
             &pv.positioning_max_reproj_error_px,
             "Inlier threshold of the check after global positioning [px]");
  b.Advanced("pv_min_point_support", &pv.min_point_support,
             "A point checks an image only if this many other images see it");
  b.Advanced("pv_use_all_pairs", &pv.use_all_pairs,
             "Use the matches of every database pair, also rejected ones");
  b.Basic("pv_min_num_inliers", &pv.min_num_inliers,
          "A pose needs this many inlier correspondences [correspondences, "
          ">= 4]");
  b.Advanced("pv_min_inlier_ratio", &pv.min_inlier_ratio,
             "A pose needs this inlier ratio");
  b.Advanced("pv_max_inliers_per_image", &pv.max_inliers_per_image,
             "Poses are scored counting at most this many inliers through "
             "each other image");
  b.Advanced("pv_min_inlier_fraction_of_estimate",
             &pv.min_inlier_fraction_of_estimate,
             "The current pose must explain this fraction of the re-estimated "
             "pose's inliers");
  b.Advanced("pv_max_rotation_difference_deg", &pv.max_rotation_difference_deg,
             "... or agree with it within this rotation [deg]");
  b.Advanced("pv_max_center_distance_ratio", &pv.max_center_distance_ratio,
             "... and this centre distance, as a fraction of the scene size");
  b.Advanced("pv_max_num_rounds", &pv.max_num_rounds,
             "Checks repeat without the failing images' points, at most this "
             "often");

  b.Group("Bundle adjustment");
  auto& ba = o->bundle_adjustment;
  b.Basic("ba_num_rounds", &ba.num_rounds,
          "Maximum bundle-adjustment rounds [rounds, >= 1]");
  b.Advanced("ba_loss_scale_px", &ba.loss_scale_px, "Robust loss scale [px]");
  b.Basic("ba_max_num_iterations", &ba.max_num_iterations,
          "Maximum iterations per solve [iterations, >= 1]");
  b.Advanced("ba_function_tolerance", &ba.function_tolerance,
             "Solver function tolerance (tightened by (50 / images)^2 above "
             "50 images)");
  b.Basic("ba_refine_focal_length", &ba.refine_focal_length,
          "Refine focal lengths [0 or 1]");
  b.Basic("ba_refine_principal_point", &ba.refine_principal_point,
          "Refine principal points (where observable, see "
          "ba_min_view_spread_deg_for_principal_point) [0 or 1]");
  b.Advanced("ba_min_view_spread_deg_for_principal_point",
             &ba.min_view_spread_deg_for_principal_point,
             "Principal points are refined only when the viewing directions "
             "spread by at least this (median angle to the mean axis; 0: "
             "whatever the spread) [deg]");
  b.Basic("ba_refine_extra_params", &ba.refine_extra_params,
          "Refine distortion parameters [0 or 1]");
  b.Advanced("ba_intrinsics_prior_px", &ba.intrinsics_prior_px,
             "Soft prior that pulls fx - fy and every distortion parameter "
             "beyond k1 towards zero: one residual each, its pixel shift at "
             "the image corner over this (0: none) [px]");
  b.Advanced("ba_bound_intrinsics", &ba.bound_intrinsics,
             "Hold refined intrinsics that run beyond their bounds on them: "
             "focal length 0.1 to 10 times the larger image side, principal "
             "point inside the image, each distortion parameter moving the "
             "image corner by at most its distance from the principal point "
             "[0 or 1]");
  b.Advanced("ba_prior_focal_length_std", &ba.prior_focal_length_std,
             "Soft prior that holds the focal length of a camera with a known "
             "focal (prior_focal_length: EXIF, or given) near it: its "
             "standard deviation as a fraction of that focal (0: none, the "
             "focal is free)");
  b.Basic("ba_max_normalized_reproj_error", &ba.max_normalized_reproj_error,
          "Reprojection-error filter (looser on the first filtering levels, "
          "by a multiplier that drops to 1; 0.01 is about 10 px at a focal "
          "length of 1000 px) [px / focal length, > 0]");
  b.Advanced("ba_initial_reproj_error_multiplier",
             &ba.initial_reproj_error_multiplier,
             "Multiplier of the reprojection-error filter on its first level; "
             "1 less on each later one, down to 1");
  b.Advanced("ba_min_tri_angle_deg", &ba.min_tri_angle_deg,
             "Points with a smaller triangulation angle are removed [deg]");
  b.Advanced("ba_min_changed_tracks_ratio", &ba.min_changed_tracks_ratio,
             "Stop once fewer tracks change in a round");
  b.Advanced("ba_skip_fixed_rotation_stage", &ba.skip_fixed_rotation_stage,
             "Skip the solve with fixed rotations");
  b.Advanced("ba_skip_joint_stage", &ba.skip_joint_stage,
             "Skip the joint solve");
  b.Advanced("ba_max_num_solve_observations", &ba.max_num_solve_observations,
             "Observations of each round's solves (at least " +
                 std::to_string(glomap::kMinSolveObservationsPerImage) +
                 " per image); above, they hold the longest tracks spread "
                 "over every image and the other points follow their poses "
                 "[observations, 0: no limit]");
  b.Advanced("ba_left_out_sweeps", &ba.left_out_sweeps,
             "After rounds whose solves left points out, sweeps over every "
             "observation: each pose refined with the points held, then each "
             "point with the poses held");

  b.Group("Retriangulation");
  auto& tri = o->retriangulation;
  b.Advanced("tri_min_num_matches", &tri.min_num_matches,
             "Pairs with fewer matches are not used");
  b.Advanced("tri_use_only_valid_pairs", &tri.use_only_valid_pairs,
             "Triangulate only from pairs kept by the earlier stages");
  b.Basic("tri_complete_max_reproj_error_px", &tri.complete_max_reproj_error_px,
          "Track completion threshold [px, > 0]");
  b.Advanced("tri_merge_max_reproj_error_px", &tri.merge_max_reproj_error_px,
             "Track merging threshold [px]");
  b.Advanced("tri_create_max_angle_error_deg", &tri.create_max_angle_error_deg,
             "Angular error to create a point [deg]");
  b.Advanced("tri_continue_max_angle_error_deg",
             &tri.continue_max_angle_error_deg,
             "Angular error to continue a track [deg]");
  b.Basic("tri_min_angle_deg", &tri.min_angle_deg,
          "Minimum triangulation angle [deg, >= 0]");
  b.Advanced("tri_max_refinements", &tri.max_refinements,
             "Maximum refinement iterations");
  b.Advanced("tri_max_refinement_change", &tri.max_refinement_change,
             "Stop refining once fewer observations change");
  b.Advanced("tri_max_num_structure_iterations",
             &tri.max_num_structure_iterations,
             "Iterations of each structure-only adjustment");
  b.Basic("tri_filter_max_reproj_error_px", &tri.filter_max_reproj_error_px,
          "Reprojection-error filter [px, > 0]");
  b.Advanced("tri_filter_min_tri_angle_deg", &tri.filter_min_tri_angle_deg,
             "Triangulation-angle filter [deg]");
  b.Advanced("tri_run_bundle_adjustment", &tri.run_bundle_adjustment,
             "Run a final bundle adjustment");
  b.Basic("tri_final_ba_max_num_iterations", &tri.final_ba_max_num_iterations,
          "Iteration cap of the final bundle adjustment [iterations, >= 1]");
  b.Advanced("tri_final_ba_loss_scale_px", &tri.final_ba_loss_scale_px,
             "Robust loss scale of the final bundle adjustment [px, 0: least "
             "squares]");
  b.Advanced("tri_final_ba_max_num_observations",
             &tri.final_ba_max_num_observations,
             "Observations of the final bundle adjustment (at least " +
                 std::to_string(glomap::kMinSolveObservationsPerImage) +
                 " per image); above, it holds the longest tracks spread over "
                 "every image and the other points follow its poses "
                 "[observations, 0: no limit]");

  b.Group("Camera clustering");
  auto& cc = o->clustering;
  b.Basic("cc_min_covisible_points", &cc.min_covisible_points,
          "Image pairs sharing fewer points are not linked [points, >= 1]");
  b.Advanced("cc_min_edge_weight", &cc.min_edge_weight,
             "Lower bound of the strong-link threshold [points]");
  b.Advanced("cc_merge_weight_ratio", &cc.merge_weight_ratio,
             "Clusters merge through links above this fraction of the "
             "threshold");
  b.Advanced("cc_min_num_merge_edges", &cc.min_num_merge_edges,
             "Links needed to merge two clusters");
  b.Advanced("cc_max_merge_rounds", &cc.max_merge_rounds, "Merging rounds");
  b.Advanced("cc_min_cluster_size", &cc.min_cluster_size, "Smallest cluster");
  return table;
}

const std::vector<std::pair<std::string, std::string>>&
RemovedGlobalMapperOptions() {
  static const auto* const removed = [] {
    const std::string small_reconstruction =
        "an internal of view-graph calibration's small incremental "
        "reconstruction";
    const std::string rp_ransac = "a RANSAC internal of relative poses";
    const std::string pv_ransac = "a RANSAC internal of pose verification";
    const std::string linear_solver =
        "the problem size at which a solve switches linear solver (the same "
        "solution either way)";
    return new std::vector<std::pair<std::string, std::string>>{
        {"vgc_function_tolerance",
         "a solver tolerance of view-graph calibration"},
        {"vgc_min_num_free_cameras_sparse", linear_solver},
        {"vgc_multi_view_min_num_matches", small_reconstruction},
        {"vgc_multi_view_max_num_keypoints_per_image", small_reconstruction},
        {"vgc_multi_view_max_num_init_attempts", small_reconstruction},
        {"vgc_multi_view_num_init_relaxations", small_reconstruction},
        {"vgc_multi_view_min_model_ratio", small_reconstruction},
        {"vgc_multi_view_num_global_refinements", small_reconstruction},
        {"vgc_multi_view_max_epipolar_error_px", small_reconstruction},
        {"rp_max_num_trials", rp_ransac},
        {"rp_min_num_trials", rp_ransac},
        {"rp_confidence", rp_ransac},
        {"rp_max_num_refinement_iterations",
         "an internal of the relative-pose refinement"},
        {"rp_max_num_refinement_points",
         "an internal of the relative-pose refinement"},
        {"ra_l1_step_convergence_threshold_rad",
         "a convergence threshold of rotation averaging"},
        {"ra_l1_initial_num_admm_iterations",
         "an ADMM internal of rotation averaging"},
        {"ra_l1_max_num_admm_iterations",
         "an ADMM internal of rotation averaging"},
        {"ra_admm_absolute_tolerance_rad",
         "an ADMM stopping tolerance of rotation averaging"},
        {"ra_admm_relative_tolerance",
         "an ADMM stopping tolerance of rotation averaging"},
        {"ra_irls_step_convergence_threshold_rad",
         "a convergence threshold of rotation averaging"},
        {"pi_function_tolerance",
         "a solver tolerance of position initialization"},
        {"pi_min_scale", "a numerical bound that keeps the scales positive"},
        {"gp_function_tolerance", "a solver tolerance of global positioning"},
        {"gp_min_scale", "a numerical bound that keeps the scales positive"},
        {"gp_init_box_size",
         "the size of the random start's box (the scale of the solution is "
         "arbitrary)"},
        {"gp_max_num_images_eigen_sparse", linear_solver},
        {"pv_ransac_confidence", pv_ransac},
        {"pv_ransac_min_num_trials", pv_ransac},
        {"pv_ransac_max_num_trials", pv_ransac},
        {"pv_max_num_refinements",
         "an internal of pose verification's pose refinement"},
        {"ba_function_tolerance_num_images",
         "the size above which bundle adjustment's tolerance tightens, a "
         "solver tolerance rule"},
        {"ba_max_num_images_dense_schur", linear_solver},
        {"tri_structure_gradient_tolerance",
         "a solver tolerance of retriangulation"},
    };
  }();
  return *removed;
}

namespace {

const std::string* FindRemovedReason(const std::string& key) {
  for (const auto& [removed_key, reason] : RemovedGlobalMapperOptions()) {
    if (removed_key == key) return &reason;
  }
  return nullptr;
}

std::string RemovedOptionError(const std::string& key,
                               const std::string& reason) {
  return "GlobalMapper." + key + " is no longer an option (" + reason +
         "; fixed in the code)";
}

// The text after `-h` that names the rest (printed at exit: COLMAP's help
// ends the process). A plain array: it outlives every static destructor.
char help_trailer[256];

void PrintHelpTrailer() { std::cout << help_trailer << std::endl; }

}  // namespace

GlobalMapperHelp FindGlobalMapperHelp(int argc, char** argv) {
  GlobalMapperHelp help = GlobalMapperHelp::kNone;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help_all" || arg == "-help_all") {
      return GlobalMapperHelp::kAll;
    }
    if (arg == "-h" || arg == "--help" || arg == "--h" || arg == "-help") {
      help = GlobalMapperHelp::kBasic;
    }
  }
  return help;
}

void AddGlobalMapperOptions(colmap::OptionManager* manager,
                            GlobalMapperOptions* options,
                            GlobalMapperHelp help) {
  for (const auto& entry : GlobalMapperOptionTable(options)) {
    if (help == GlobalMapperHelp::kBasic &&
        entry.tier != GlobalMapperOptionTier::kBasic) {
      continue;
    }
    const std::string name = "GlobalMapper." + entry.key;
    std::visit(
        [&](auto* value) {
          manager->AddDefaultOption(name, value, entry.help);
        },
        entry.value);
  }
}

void PrintGlobalMapperHelpAndExit(colmap::OptionManager* manager,
                                  const char* program,
                                  const std::string& command,
                                  GlobalMapperHelp help) {
  if (help == GlobalMapperHelp::kBasic) {
    GlobalMapperOptions options;
    int num_advanced = 0;
    for (const auto& entry : GlobalMapperOptionTable(&options)) {
      num_advanced += entry.tier == GlobalMapperOptionTier::kAdvanced;
    }
    snprintf(help_trailer, sizeof(help_trailer),
             "%d more options (solver and stage details): colmap %s "
             "--help_all",
             num_advanced, command.c_str());
    std::atexit(PrintHelpTrailer);
  }
  // Only the help: nothing else on the command line can make Parse fail
  // (e.g. an advanced option, which `-h` does not add), so Parse prints the
  // help and ends the process with exit code 0, running PrintHelpTrailer.
  std::string help_flag = "--help";
  char* args[] = {const_cast<char*>(program), help_flag.data(), nullptr};
  manager->Parse(2, args);
  std::exit(EXIT_SUCCESS);
}

std::string CheckForRemovedGlobalMapperOptions(
    int argc, char** argv, const std::string& project_path) {
  const std::string prefix = "--GlobalMapper.";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind(prefix, 0) != 0) continue;
    const std::string key =
        arg.substr(prefix.size(), arg.find('=') - prefix.size());
    if (const std::string* reason = FindRemovedReason(key)) {
      return "Command line: " + RemovedOptionError(key, *reason) + ".";
    }
  }
  if (project_path.empty()) return "";
  // COLMAP's project files are INI files; their sections are read by
  // OptionManager::Read, which would refuse the key with less detail.
  boost::property_tree::ptree tree;
  try {
    boost::property_tree::read_ini(project_path, tree);
  } catch (const std::exception&) {
    return "";  // OptionManager::Read reports what is wrong with the file.
  }
  const auto check = [&](const std::string& key) -> std::string {
    if (const std::string* reason = FindRemovedReason(key)) {
      return project_path + ": " + RemovedOptionError(key, *reason) + ".";
    }
    return "";
  };
  if (const auto section = tree.get_child_optional("GlobalMapper")) {
    for (const auto& [key, node] : *section) {
      if (std::string error = check(key); !error.empty()) return error;
    }
  }
  // Keys outside a section ("GlobalMapper.<key>=...").
  const std::string section_prefix = "GlobalMapper.";
  for (const auto& [key, node] : tree) {
    if (key.rfind(section_prefix, 0) != 0) continue;
    if (std::string error = check(key.substr(section_prefix.size()));
        !error.empty()) {
      return error;
    }
  }
  return "";
}

bool SetGlobalMapperOption(const std::string& key, const std::string& text,
                           GlobalMapperOptions* options, std::string* error) {
  std::vector<GlobalMapperOptionEntry> table = GlobalMapperOptionTable(options);
  const auto it =
      std::find_if(table.begin(), table.end(),
                   [&key](const auto& entry) { return entry.key == key; });
  if (it == table.end()) {
    if (const std::string* reason = FindRemovedReason(key)) {
      *error = RemovedOptionError(key, *reason);
    } else {
      *error = "unknown option GlobalMapper." + key;
    }
    return false;
  }
  try {
    size_t end = 0;
    std::visit(
        [&](auto* value) {
          using T = std::remove_pointer_t<decltype(value)>;
          if constexpr (std::is_same_v<T, bool>) {
            if (text != "0" && text != "1" && text != "true" &&
                text != "false") {
              throw std::invalid_argument(text);
            }
            *value = text == "1" || text == "true";
            end = text.size();
          } else if constexpr (std::is_same_v<T, int>) {
            *value = std::stoi(text, &end);
          } else {
            *value = std::stod(text, &end);
          }
        },
        it->value);
    if (end != text.size()) throw std::invalid_argument(text);
  } catch (const std::exception&) {
    *error = "invalid value '" + text + "' for GlobalMapper." + key;
    return false;
  }
  return true;
}

bool ReadGlobalMapperOptionsFile(const std::string& path,
                                 GlobalMapperOptions* options) {
  boost::property_tree::ptree tree;
  try {
    boost::property_tree::read_ini(path, tree);
  } catch (const std::exception& e) {
    LOG(WARNING) << "Cannot read " << path << ": " << e.what();
    return false;
  }
  const auto section = tree.get_child_optional("GlobalMapper");
  if (!section) return true;
  // Files written when they were options hold every removed key: skipped,
  // with one warning for all of them.
  std::string removed_keys;
  for (const auto& [key, node] : *section) {
    if (FindRemovedReason(key) != nullptr) {
      removed_keys += (removed_keys.empty() ? "" : ", ") + key;
      continue;
    }
    std::string error;
    if (SetGlobalMapperOption(key, node.get_value<std::string>(), options,
                              &error)) {
      continue;
    }
    LOG(WARNING) << path << ": " << error;
    // Unknown keys (from a newer version) are skipped; bad values are not.
    if (error.rfind("unknown", 0) != 0) return false;
  }
  if (!removed_keys.empty()) {
    LOG(WARNING) << path << ": ignored what are no longer options (solver "
                 << "internals, fixed in the code): " << removed_keys;
  }
  return true;
}

bool WriteGlobalMapperOptionsFile(const std::string& path,
                                  const GlobalMapperOptions& options) {
  GlobalMapperOptions copy = options;
  boost::property_tree::ptree tree;
  for (const auto& entry : GlobalMapperOptionTable(&copy)) {
    std::visit(
        [&](auto* value) { tree.put("GlobalMapper." + entry.key, *value); },
        entry.value);
  }
  try {
    boost::property_tree::write_ini(path, tree);
  } catch (const std::exception& e) {
    LOG(WARNING) << "Cannot write " << path << ": " << e.what();
    return false;
  }
  return true;
}

}  // namespace glomap
