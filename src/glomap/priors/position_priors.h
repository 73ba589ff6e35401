// Camera position priors (GPS, or known positions in metres) from the
// database's images.prior_tx/ty/tz: validated and converted into one metric
// frame, in which global positioning and bundle adjustment then solve (issue
// 12). COLMAP 3.8's feature_extractor stores EXIF GPS there as latitude,
// longitude (deg) and altitude (m); other tools store metric positions.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/util/status.h"

namespace glomap {

struct PositionPriorOptions {
  // Use the priors in the solve. Off: the model is in an arbitrary frame, as
  // without priors (the log says when priors exist but are unused).
  bool use_position_priors = false;
  // The priors are latitude, longitude (deg) and altitude (m, WGS84), as
  // COLMAP's feature extractor stores EXIF GPS; they are converted into a
  // local east-north-up frame in metres around the first image's prior (or
  // into ECEF with `prior_use_ecef`). Off: they are metric already.
  bool prior_is_gps = false;
  // With prior_is_gps: earth-centred, earth-fixed metres instead of ENU.
  bool prior_use_ecef = false;
  // One standard deviation of a prior, every axis [m].
  double prior_position_std_m = 1.0;
  // Scale of the robust (Cauchy) loss on a prior's error, in standard
  // deviations: a prior farther off counts less and less (multipath, a phone
  // indoors).
  double prior_loss_scale = 3.0;
  // After global positioning, a prior farther than this many standard
  // deviations from its camera (in the prior frame) is rejected and named in
  // the log; bundle adjustment then leaves it out.
  double prior_max_error_std = 5.0;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// The frame of a model solved with priors, written beside it
// (OUT/k/georegistration.txt) and logged.
struct Georegistration {
  // False: no priors were used, the frame is arbitrary.
  bool georegistered = false;
  // "ENU" (east, north, up in metres around `origin_lla`), "ECEF" (metres,
  // WGS84), or "metric" (the priors' own metric frame, as stored in the
  // database).
  std::string frame;
  // ENU origin: latitude, longitude (deg), altitude (m, WGS84 ellipsoid):
  // the prior of the image with the smallest id among those with a usable
  // prior. Zero for the ECEF and metric frames.
  Eigen::Vector3d origin_lla = Eigen::Vector3d::Zero();
  // Images whose prior took part, and those rejected as wrong (by name, in
  // the order they were rejected). PreparePositionPriors sets
  // num_priors_used to the number of usable priors; the solve updates both.
  size_t num_priors_used = 0;
  std::vector<std::string> rejected_prior_image_names;
  // The priors' noise, one standard deviation per axis [m], as the final
  // model shows it (EstimatePriorNoiseStdM over every prior, rejected ones
  // included); NaN until the model is made, or with too few priors.
  double prior_noise_estimate_m = std::numeric_limits<double>::quiet_NaN();

  // The text of georegistration.txt: comments ("# ...") and "key value"
  // lines: frame, origin_latitude_deg, origin_longitude_deg,
  // origin_altitude_m (ENU only, 17 significant digits), priors_used,
  // priors_rejected, prior_noise_estimate_m (when known), then one
  // "rejected_prior_image <name>" line per rejected image.
  std::string ToText() const;
};

// Camera centre priors of the registered-to-be images, in the metric frame
// the solve uses.
struct PositionPriors {
  std::unordered_map<colmap::image_t, Eigen::Vector3d> center_in_frame;
  Georegistration georegistration;

  bool empty() const { return center_in_frame.empty(); }
};

// Variances of `positions` along their principal axes, ascending (the
// spread across a line, then along it): how well priors fix a similarity.
Eigen::Vector3d PrincipalVariances(
    const std::vector<Eigen::Vector3d>& positions);

// Reads the TvecPrior() of every image of `reconstruction` (registered or
// not; as the database reader stored it, NaN = unset), validates and
// converts the set ones: GPS into ENU around the prior of the image with the
// smallest id (or into ECEF with prior_use_ecef), metric priors as they are.
// Images without a prior are left out of `priors` and still take part in
// the solve. When priors are returned, `priors->georegistration` is filled
// for them: georegistered, frame, origin_lla, num_priors_used (the count of
// `center_in_frame`), no rejected images yet.
//
// Errors (one line, naming an image): prior_is_gps with a latitude outside
// [-90, 90] or a longitude outside [-180, 180] (metric values read as GPS).
//
// Warnings, and an empty `priors` (the free solve; `priors` is then
// default-constructed, georegistered false):
//  - options say off (one line says how many images have priors);
//  - fewer than three distinct priors (a similarity is not fixed);
//  - all priors (nearly) identical: their largest RMS spread about their
//    centre, along any axis, is at most prior_position_std_m;
//  - all priors collinear: their RMS distance from the best-fitting line is
//    at most 1e-4 of their spread along it (the rotation about it is free).
// Warnings only, the priors are used: priors that are not finite (NaN or
// infinite in a coordinate; left out, counted), priors for fewer than half
// of the images, priors nearly collinear (their spread across the line is
// within prior_position_std_m: the rotation about the line is weakly fixed).
Status PreparePositionPriors(const PositionPriorOptions& options,
                             const colmap::Reconstruction& reconstruction,
                             PositionPriors* priors);

}  // namespace glomap
