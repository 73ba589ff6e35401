#include "colmap_ext/global_mapper_options.h"

#include <algorithm>
#include <boost/property_tree/ini_parser.hpp>
#include <boost/property_tree/ptree.hpp>
#include <stdexcept>
#include <type_traits>

#include "util/logging.h"
#include "util/option_manager.h"

namespace glomap {
namespace {

class TableBuilder {
 public:
  explicit TableBuilder(std::vector<GlobalMapperOptionEntry>* table)
      : table_(table) {}

  void Group(const std::string& group) { group_ = group; }

  template <typename T>
  void Add(const std::string& key, T* value, const std::string& help) {
    table_->push_back({group_, key, value, help});
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
  b.Add("min_num_matches", &o->database.min_num_matches,
        "Pairs with fewer verified matches are ignored");
  b.Add("ignore_watermarks", &o->database.ignore_watermarks,
        "Ignore pairs the matcher flagged as watermark");
  b.Add("random_seed", &o->random_seed,
        "Seed of every random choice: same input and seed, same model");
  b.Add("num_threads", &o->num_threads,
        "Most threads any stage computes on at a time (-1: all cores): "
        "relative poses, calibration, positioning, pose verification, bundle "
        "adjustment, retriangulation; colours are read on one. Libraries "
        "(CHOLMOD, BLAS, Eigen) start no threads of their own. With 1, the "
        "same input and seed give the same model bit for bit");
  b.Add("min_residuals_per_ceres_thread", &o->min_residuals_per_ceres_thread,
        "Small-problem rule of every Ceres solve (calibration, positioning, "
        "bundle adjustment, retriangulation): one thread per this many "
        "residual blocks (about one per observation), up to num_threads, so "
        "that smaller problems solve on one thread [residual blocks per "
        "thread]");
  b.Add("min_model_size", &o->min_model_size,
        "Camera clusters with fewer images are not written (at least 2: "
        "a two-image project needs 2)");
  b.Add("merge_identical_cameras", &o->merge_identical_cameras,
        "Cameras with identical focal prior flag, model, size and parameters "
        "(one camera per image, as feature_extractor writes them by default) "
        "are calibrated and refined as one camera, unless bundle adjustment "
        "finds that they fit clearly better apart; every image keeps its own "
        "camera in the output");
  b.Add("skip_view_graph_calibration", &o->skip_view_graph_calibration,
        "Keep the database's focal lengths");
  b.Add("skip_bundle_adjustment", &o->skip_bundle_adjustment,
        "Skip the global bundle-adjustment rounds");
  b.Add("skip_retriangulation", &o->skip_retriangulation,
        "Skip retriangulation");
  b.Add("skip_clustering", &o->skip_clustering,
        "Write all registered images as one model");
  b.Add("skip_pose_verification", &o->skip_pose_verification,
        "Do not check the camera poses against the structure (not "
        "recommended: a wrongly placed camera then goes unnoticed)");
  b.Add("init_positions_from_pairs", &o->init_positions_from_pairs,
        "Start global positioning from camera centres fitted to the pairs' "
        "translation directions instead of random ones (keeps long "
        "streets in one model; see gp_random_start_unless_converged)");

  b.Group("Position priors");
  auto& pp = o->position_priors;
  b.Add("use_position_priors", &pp.use_position_priors,
        "Solve with the images' position priors (images.prior_tx/ty/tz: GPS "
        "or known positions): the model comes out in metres in their frame "
        "(georegistration.txt beside it)");
  b.Add("prior_is_gps", &pp.prior_is_gps,
        "The priors are latitude, longitude [deg] and altitude [m] (WGS84), "
        "as COLMAP's feature extractor stores EXIF GPS; solved in east-north-"
        "up metres around the first image's prior. Off: metric positions [m]");
  b.Add("prior_use_ecef", &pp.prior_use_ecef,
        "With prior_is_gps: solve in earth-centred, earth-fixed metres "
        "instead of east-north-up");
  b.Add("prior_position_std_m", &pp.prior_position_std_m,
        "Standard deviation of a prior, each axis [m]");
  b.Add("prior_loss_scale", &pp.prior_loss_scale,
        "Cauchy loss scale of a prior's error: farther off, it counts less "
        "and less [standard deviations]");
  b.Add("prior_max_error_std", &pp.prior_max_error_std,
        "After global positioning, priors farther from their camera are "
        "rejected and named in the log [standard deviations]");

  b.Group("View graph calibration");
  auto& vgc = o->view_graph_calibration;
  b.Add("vgc_calibrate_identical_cameras_as_one",
        &vgc.calibrate_identical_cameras_as_one,
        "Cameras without a focal prior with identical model, size and "
        "parameters (one camera per image, as feature_extractor writes them) "
        "get one focal length in view-graph calibration; bundle adjustment "
        "still refines each");
  b.Add("vgc_min_focal_ratio", &vgc.min_focal_ratio,
        "Reject a new focal length below this ratio of the old one");
  b.Add("vgc_max_focal_ratio", &vgc.max_focal_ratio,
        "Reject a new focal length above this ratio of the old one");
  b.Add("vgc_max_two_view_error", &vgc.max_two_view_error,
        "Pairs whose focal residual exceeds this are rejected");
  b.Add("vgc_loss_scale", &vgc.loss_scale, "Cauchy loss scale");
  b.Add("vgc_coarse_loss_scale", &vgc.coarse_loss_scale,
        "Cauchy loss scale of the first solve (at least vgc_loss_scale)");
  b.Add("vgc_max_num_iterations", &vgc.max_num_iterations,
        "Maximum solver iterations");
  b.Add("vgc_function_tolerance", &vgc.function_tolerance,
        "Solver function tolerance");
  b.Add("vgc_min_num_free_cameras_sparse", &vgc.min_num_free_cameras_sparse,
        "From this many cameras without a focal prior on, solve with a sparse "
        "Cholesky; below, with dense QR");
  b.Add("vgc_multi_view_num_images", &vgc.multi_view_num_images,
        "Images of the small incremental reconstruction that calibrates "
        "focal lengths the fundamental matrices miss (0: off)");
  b.Add("vgc_multi_view_min_rotation_bias_deg",
        &vgc.multi_view_min_rotation_bias_deg,
        "Use its focal lengths only where they change the relative "
        "rotations by at least this much in the median [deg]");
  b.Add("vgc_multi_view_min_num_matches", &vgc.multi_view_min_num_matches,
        "Pairs with fewer matches are not used by the small reconstruction");
  b.Add("vgc_multi_view_min_num_images_per_camera",
        &vgc.multi_view_min_num_images_per_camera,
        "A camera's focal length is taken from the small reconstruction only "
        "if this many of its images are in it");
  b.Add("vgc_multi_view_max_num_keypoints_per_image",
        &vgc.multi_view_max_num_keypoints_per_image,
        "Keypoints per image the small reconstruction uses at most (the most "
        "matched ones)");
  b.Add("vgc_multi_view_max_num_init_attempts",
        &vgc.multi_view_max_num_init_attempts,
        "Initial pairs tried per level of the small reconstruction");
  b.Add("vgc_multi_view_num_init_relaxations",
        &vgc.multi_view_num_init_relaxations,
        "Levels of the initial-pair search (each later one halves the "
        "inliers and triangulation angle required)");
  b.Add("vgc_multi_view_min_model_ratio", &vgc.multi_view_min_model_ratio,
        "Initial pairs are tried until a small reconstruction holds this "
        "fraction of the selected images");
  b.Add("vgc_multi_view_num_global_refinements",
        &vgc.multi_view_num_global_refinements,
        "Bundle adjustment and filtering passes of each global refinement of "
        "the small reconstruction");
  b.Add("vgc_multi_view_max_epipolar_error_px",
        &vgc.multi_view_max_epipolar_error_px,
        "RANSAC threshold of the relative rotations the small "
        "reconstruction is compared with [px]");

  b.Group("Relative poses");
  auto& rp = o->relative_pose;
  b.Add("rp_use_stored_geometry", &rp.use_stored_geometry,
        "Start each pair from the database's two-view geometry (RANSAC only "
        "where it fails or is missing)");
  b.Add("rp_max_epipolar_error_px", &rp.max_epipolar_error_px,
        "RANSAC threshold of the essential matrix [px]");
  b.Add("rp_max_num_trials", &rp.max_num_trials, "Maximum RANSAC trials");
  b.Add("rp_min_num_trials", &rp.min_num_trials, "Minimum RANSAC trials");
  b.Add("rp_confidence", &rp.confidence, "RANSAC confidence");
  b.Add("rp_max_num_refinement_iterations", &rp.max_num_refinement_iterations,
        "Iterations of the relative-pose refinement");
  b.Add("rp_max_num_refinement_points", &rp.max_num_refinement_points,
        "Matches used by the relative-pose refinement");
  b.Add("rp_max_epipolar_error_E_px", &rp.max_epipolar_error_E_px,
        "Inlier threshold of calibrated pairs [px]");
  b.Add("rp_max_epipolar_error_F_px", &rp.max_epipolar_error_F_px,
        "Inlier threshold of uncalibrated pairs [px]");
  b.Add("rp_max_epipolar_error_H_px", &rp.max_epipolar_error_H_px,
        "Inlier threshold of planar or panoramic pairs [px]");
  b.Add("rp_min_epipole_angle_deg", &rp.min_epipole_angle_deg,
        "Matches closer to the epipole are not inliers [deg]");
  b.Add("rp_min_num_inliers", &rp.min_num_inliers,
        "Pairs with fewer inliers are rejected");
  b.Add("rp_min_inlier_ratio", &rp.min_inlier_ratio,
        "Pairs with a lower inlier ratio are rejected");

  b.Group("Rotation averaging");
  auto& ra = o->rotation_averaging;
  b.Add("ra_max_num_l1_iterations", &ra.max_num_l1_iterations,
        "Maximum L1 iterations");
  b.Add("ra_l1_step_convergence_threshold_rad",
        &ra.l1_step_convergence_threshold_rad, "L1 convergence [rad]");
  b.Add("ra_l1_initial_num_admm_iterations", &ra.l1_initial_num_admm_iterations,
        "ADMM iterations of the first L1 solve (doubling in each later one)");
  b.Add("ra_l1_max_num_admm_iterations", &ra.l1_max_num_admm_iterations,
        "ADMM iterations of an L1 solve at most");
  b.Add("ra_admm_absolute_tolerance_rad", &ra.admm_absolute_tolerance_rad,
        "ADMM absolute stopping tolerance per residual coordinate [rad]");
  b.Add("ra_admm_relative_tolerance", &ra.admm_relative_tolerance,
        "ADMM relative stopping tolerance");
  b.Add("ra_max_num_irls_iterations", &ra.max_num_irls_iterations,
        "Maximum IRLS iterations");
  b.Add("ra_irls_step_convergence_threshold_rad",
        &ra.irls_step_convergence_threshold_rad, "IRLS convergence [rad]");
  b.Add("ra_irls_loss_parameter_sigma_deg", &ra.irls_loss_parameter_sigma_deg,
        "Geman-McClure scale [deg]");
  b.Add("ra_max_rotation_error_deg", &ra.max_rotation_error_deg,
        "Pairs disagreeing with the global rotations by more are rejected "
        "[deg]");
  b.Add("ra_num_rounds", &ra.num_rounds,
        "Solve, reject, solve again: number of solves");
  b.Add("ra_use_triangle_support_in_tree", &ra.use_triangle_support_in_tree,
        "Start from a spanning tree of pairs that close consistent triangles");

  b.Group("Tracks");
  auto& tr = o->tracks;
  b.Add("track_max_intra_image_distance_px", &tr.max_intra_image_distance_px,
        "Tracks with two observations farther apart in one image are "
        "dropped [px]");
  b.Add("track_min_num_views_per_track", &tr.min_num_views_per_track,
        "Minimum images per track");
  b.Add("track_max_num_views_per_track", &tr.max_num_views_per_track,
        "Maximum images per track");
  b.Add("track_max_num_tracks", &tr.max_num_tracks, "Maximum tracks");
  b.Add("track_min_num_tracks_per_view", &tr.min_num_tracks_per_view,
        "Keep the longest tracks until every image has this many (-1: all "
        "tracks)");

  b.Group("Position initialization");
  auto& pi = o->position_initialization;
  b.Add("pi_loss_scale", &pi.loss_scale,
        "Huber loss scale on the pairs' translation directions");
  b.Add("pi_max_num_iterations", &pi.max_num_iterations,
        "Maximum solver iterations");
  b.Add("pi_function_tolerance", &pi.function_tolerance,
        "Solver function tolerance");
  b.Add("pi_min_scale", &pi.min_scale,
        "Lower bound of every pair's scale [1 / scene units]");

  b.Group("Global positioning");
  auto& gp = o->global_positioning;
  b.Add("gp_loss_scale", &gp.loss_scale, "Huber loss scale");
  b.Add("gp_max_num_iterations", &gp.max_num_iterations,
        "Maximum solver iterations");
  b.Add("gp_function_tolerance", &gp.function_tolerance,
        "Solver function tolerance");
  b.Add("gp_optimize_positions", &gp.optimize_positions,
        "Optimize camera positions");
  b.Add("gp_optimize_points", &gp.optimize_points, "Optimize points");
  b.Add("gp_optimize_scales", &gp.optimize_scales, "Optimize ray scales");
  b.Add("gp_min_scale", &gp.min_scale,
        "Lower bound of every ray scale (keeps points in front of their "
        "cameras) [1 / scene units]");
  b.Add("gp_random_start_unless_converged", &gp.random_start_unless_converged,
        "With init_positions_from_pairs: if that start does not converge, "
        "also solve from the random start and keep the lower cost");
  b.Add("gp_random_start_max_num_images", &gp.random_start_max_num_images,
        "Up to this many images, solve the random start also when the "
        "start from the pairs converges");
  b.Add("gp_random_start_check_iterations", &gp.random_start_check_iterations,
        "That random solve is stopped after this many iterations if its cost "
        "is still above the other start's final cost (0: never)");
  b.Add("gp_init_box_size", &gp.init_box_size,
        "Size of the random initialisation box");
  b.Add("gp_uncalibrated_weight", &gp.uncalibrated_weight,
        "Weight of cameras without a focal prior");
  b.Add("gp_max_angular_error_deg", &gp.max_angular_error_deg,
        "Observations with a larger angular error are removed [deg]");
  b.Add("gp_uncalibrated_angular_error_factor",
        &gp.uncalibrated_angular_error_factor,
        "For cameras without a focal prior, the angular-error limit is this "
        "multiple of gp_max_angular_error_deg");
  b.Add("gp_min_tri_angle_deg", &gp.min_tri_angle_deg,
        "Points with a smaller triangulation angle are removed [deg]");
  b.Add("gp_min_inlier_observation_ratio", &gp.min_inlier_observation_ratio,
        "Fail if fewer observations survive filtering");
  b.Add("gp_max_num_images_eigen_sparse", &gp.max_num_images_eigen_sparse,
        "Below this many images, solve with Eigen's sparse Cholesky; above, "
        "with CHOLMOD and a Schur complement");
  b.Add("gp_prior_max_num_iterations", &gp.prior_max_num_iterations,
        "With position priors: iterations of the second solve, in the prior "
        "frame with the prior term");

  b.Group("Pose verification");
  auto& pv = o->pose_verification;
  b.Add("pv_max_reproj_error_px", &pv.max_reproj_error_px,
        "Inlier threshold of the check before the output [px]");
  b.Add("pv_positioning_max_reproj_error_px",
        &pv.positioning_max_reproj_error_px,
        "Inlier threshold of the check after global positioning [px]");
  b.Add("pv_min_point_support", &pv.min_point_support,
        "A point checks an image only if this many other images see it");
  b.Add("pv_use_all_pairs", &pv.use_all_pairs,
        "Use the matches of every database pair, also rejected ones");
  b.Add("pv_min_num_inliers", &pv.min_num_inliers,
        "A pose needs this many inlier correspondences");
  b.Add("pv_min_inlier_ratio", &pv.min_inlier_ratio,
        "A pose needs this inlier ratio");
  b.Add("pv_max_inliers_per_image", &pv.max_inliers_per_image,
        "Poses are scored counting at most this many inliers through each "
        "other image");
  b.Add("pv_min_inlier_fraction_of_estimate",
        &pv.min_inlier_fraction_of_estimate,
        "The current pose must explain this fraction of the re-estimated "
        "pose's inliers");
  b.Add("pv_max_rotation_difference_deg", &pv.max_rotation_difference_deg,
        "... or agree with it within this rotation [deg]");
  b.Add("pv_max_center_distance_ratio", &pv.max_center_distance_ratio,
        "... and this centre distance, as a fraction of the scene size");
  b.Add("pv_max_num_rounds", &pv.max_num_rounds,
        "Checks repeat without the failing images' points, at most this "
        "often");
  b.Add("pv_ransac_confidence", &pv.ransac_confidence, "RANSAC confidence");
  b.Add("pv_ransac_min_num_trials", &pv.ransac_min_num_trials,
        "Minimum RANSAC trials");
  b.Add("pv_ransac_max_num_trials", &pv.ransac_max_num_trials,
        "Maximum RANSAC trials");
  b.Add("pv_max_num_refinements", &pv.max_num_refinements,
        "The RANSAC pose is refined on its inliers while its score improves, "
        "at most this often");

  b.Group("Bundle adjustment");
  auto& ba = o->bundle_adjustment;
  b.Add("ba_num_rounds", &ba.num_rounds, "Maximum bundle-adjustment rounds");
  b.Add("ba_loss_scale_px", &ba.loss_scale_px, "Robust loss scale [px]");
  b.Add("ba_max_num_iterations", &ba.max_num_iterations,
        "Maximum iterations per solve");
  b.Add("ba_function_tolerance", &ba.function_tolerance,
        "Solver function tolerance");
  b.Add("ba_function_tolerance_num_images", &ba.function_tolerance_num_images,
        "Above this many images, the function tolerance is scaled by (this / "
        "images)^2");
  b.Add("ba_max_num_images_dense_schur", &ba.max_num_images_dense_schur,
        "Up to this many images, solve with a dense Schur complement; above, "
        "with a sparse one (CHOLMOD)");
  b.Add("ba_refine_focal_length", &ba.refine_focal_length,
        "Refine focal lengths");
  b.Add("ba_refine_principal_point", &ba.refine_principal_point,
        "Refine principal points (where observable, see the next option)");
  b.Add("ba_min_view_spread_deg_for_principal_point",
        &ba.min_view_spread_deg_for_principal_point,
        "Principal points are refined only when the viewing directions spread "
        "by at least this (median angle to the mean axis; 0: whatever the "
        "spread) [deg]");
  b.Add("ba_refine_extra_params", &ba.refine_extra_params,
        "Refine distortion parameters");
  b.Add("ba_intrinsics_prior_px", &ba.intrinsics_prior_px,
        "Soft prior that pulls fx - fy and every distortion parameter beyond "
        "k1 towards zero: one residual each, its pixel shift at the image "
        "corner over this (0: none) [px]");
  b.Add("ba_prior_focal_length_std", &ba.prior_focal_length_std,
        "Soft prior that holds the focal length of a camera with a known "
        "focal (prior_focal_length: EXIF, or given) near it: its standard "
        "deviation as a fraction of that focal (0: none, the focal is free)");
  b.Add("ba_max_normalized_reproj_error", &ba.max_normalized_reproj_error,
        "Reprojection-error filter, normalized image units (looser on the "
        "first filtering levels, by a multiplier that drops to 1)");
  b.Add("ba_initial_reproj_error_multiplier",
        &ba.initial_reproj_error_multiplier,
        "Multiplier of the reprojection-error filter on its first level; 1 "
        "less on each later one, down to 1");
  b.Add("ba_min_tri_angle_deg", &ba.min_tri_angle_deg,
        "Points with a smaller triangulation angle are removed [deg]");
  b.Add("ba_min_changed_tracks_ratio", &ba.min_changed_tracks_ratio,
        "Stop once fewer tracks change in a round");
  b.Add("ba_skip_fixed_rotation_stage", &ba.skip_fixed_rotation_stage,
        "Skip the solve with fixed rotations");
  b.Add("ba_skip_joint_stage", &ba.skip_joint_stage, "Skip the joint solve");

  b.Group("Retriangulation");
  auto& tri = o->retriangulation;
  b.Add("tri_min_num_matches", &tri.min_num_matches,
        "Pairs with fewer matches are not used");
  b.Add("tri_use_only_valid_pairs", &tri.use_only_valid_pairs,
        "Triangulate only from pairs kept by the earlier stages");
  b.Add("tri_complete_max_reproj_error_px", &tri.complete_max_reproj_error_px,
        "Track completion threshold [px]");
  b.Add("tri_merge_max_reproj_error_px", &tri.merge_max_reproj_error_px,
        "Track merging threshold [px]");
  b.Add("tri_create_max_angle_error_deg", &tri.create_max_angle_error_deg,
        "Angular error to create a point [deg]");
  b.Add("tri_continue_max_angle_error_deg", &tri.continue_max_angle_error_deg,
        "Angular error to continue a track [deg]");
  b.Add("tri_min_angle_deg", &tri.min_angle_deg,
        "Minimum triangulation angle [deg]");
  b.Add("tri_max_refinements", &tri.max_refinements,
        "Maximum refinement iterations");
  b.Add("tri_max_refinement_change", &tri.max_refinement_change,
        "Stop refining once fewer observations change");
  b.Add("tri_max_num_structure_iterations", &tri.max_num_structure_iterations,
        "Iterations of each structure-only adjustment");
  b.Add("tri_structure_gradient_tolerance", &tri.structure_gradient_tolerance,
        "Solver gradient tolerance of the structure-only adjustment");
  b.Add("tri_filter_max_reproj_error_px", &tri.filter_max_reproj_error_px,
        "Reprojection-error filter [px]");
  b.Add("tri_filter_min_tri_angle_deg", &tri.filter_min_tri_angle_deg,
        "Triangulation-angle filter [deg]");
  b.Add("tri_run_bundle_adjustment", &tri.run_bundle_adjustment,
        "Run a final bundle adjustment");
  b.Add("tri_final_ba_max_num_iterations", &tri.final_ba_max_num_iterations,
        "Iteration cap of the final bundle adjustment");

  b.Group("Camera clustering");
  auto& cc = o->clustering;
  b.Add("cc_min_covisible_points", &cc.min_covisible_points,
        "Image pairs sharing fewer points are not linked");
  b.Add("cc_min_edge_weight", &cc.min_edge_weight,
        "Lower bound of the strong-link threshold [points]");
  b.Add("cc_merge_weight_ratio", &cc.merge_weight_ratio,
        "Clusters merge through links above this fraction of the threshold");
  b.Add("cc_min_num_merge_edges", &cc.min_num_merge_edges,
        "Links needed to merge two clusters");
  b.Add("cc_max_merge_rounds", &cc.max_merge_rounds, "Merging rounds");
  b.Add("cc_min_cluster_size", &cc.min_cluster_size, "Smallest cluster");
  return table;
}

void AddGlobalMapperOptions(colmap::OptionManager* manager,
                            GlobalMapperOptions* options) {
  for (const auto& entry : GlobalMapperOptionTable(options)) {
    const std::string name = "GlobalMapper." + entry.key;
    std::visit(
        [&](auto* value) {
          manager->AddDefaultOption(name, value, entry.help);
        },
        entry.value);
  }
}

bool SetGlobalMapperOption(const std::string& key, const std::string& text,
                           GlobalMapperOptions* options, std::string* error) {
  std::vector<GlobalMapperOptionEntry> table = GlobalMapperOptionTable(options);
  const auto it =
      std::find_if(table.begin(), table.end(),
                   [&key](const auto& entry) { return entry.key == key; });
  if (it == table.end()) {
    *error = "unknown option GlobalMapper." + key;
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
  for (const auto& [key, node] : *section) {
    std::string error;
    if (SetGlobalMapperOption(key, node.get_value<std::string>(), options,
                              &error)) {
      continue;
    }
    LOG(WARNING) << path << ": " << error;
    // Unknown keys (from a newer version) are skipped; bad values are not.
    if (error.rfind("unknown", 0) != 0) return false;
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
