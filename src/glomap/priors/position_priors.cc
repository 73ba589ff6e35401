#include "glomap/priors/position_priors.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <tuple>

#include "base/gps.h"
#include "glomap/util/options_check.h"
#include "util/logging.h"

namespace glomap {
namespace {

// Priors whose RMS distance from their best-fitting line is at most this
// fraction of their RMS spread along it are collinear: converted GPS of a
// straight track deviates from a line by the earth's curvature only (2 cm
// over 1 km, 2e-5), far below this; real collinear-looking data with noise
// lies far above it.
constexpr double kCollinearRelativeSpread = 1e-4;

std::string PriorText(const Eigen::Vector3d& prior) {
  std::ostringstream text;
  text << std::setprecision(10) << "(" << prior.x() << ", " << prior.y() << ", "
       << prior.z() << ")";
  return text.str();
}

std::string ImageText(const colmap::Image& image) {
  return "image " + image.Name() + " (id " + std::to_string(image.ImageId()) +
         ")";
}

std::string CountOf(size_t count, const std::string& noun) {
  return std::to_string(count) + " " + noun + (count == 1 ? "" : "s");
}

bool IsLatitudeLongitude(const Eigen::Vector3d& prior) {
  return std::abs(prior.x()) <= 90 && std::abs(prior.y()) <= 180;
}

// The priors as the solve gets them: ENU around the first prior (the image
// with the smallest id), ECEF, or as given.
std::vector<Eigen::Vector3d> ConvertToFrame(
    const PositionPriorOptions& options,
    const std::vector<Eigen::Vector3d>& priors, Georegistration* frame) {
  if (!options.prior_is_gps) {
    frame->frame = "metric";
    return priors;
  }
  const colmap::GPSTransform gps(colmap::GPSTransform::WGS84);
  if (options.prior_use_ecef) {
    frame->frame = "ECEF";
    return gps.EllToXYZ(priors);
  }
  frame->frame = "ENU";
  frame->origin_lla = priors.front();
  // COLMAP 3.8's EllToENU measures from the first point of its list, not
  // from (lat0, lon0): the origin is the first prior, so the list as it is
  // gives ENU around it (with the rotation of the origin's tangent plane).
  return gps.EllToENU(priors, frame->origin_lla.x(), frame->origin_lla.y());
}

// Why `positions` cannot fix a similarity (translation, rotation, scale),
// or "" if they can. `*nearly_collinear_warning` receives a warning for
// positions whose rotation about a line is fixed by little more than noise.
std::string Degeneracy(const PositionPriorOptions& options,
                       const std::vector<Eigen::Vector3d>& positions,
                       std::string* nearly_collinear_warning) {
  std::vector<std::tuple<double, double, double>> distinct;
  for (const Eigen::Vector3d& p : positions) {
    distinct.emplace_back(p.x(), p.y(), p.z());
  }
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  if (distinct.size() == 1) {
    return "all " + CountOf(positions.size(), "position prior") +
           " are identical";
  }
  if (distinct.size() < 3) {
    return "fewer than three distinct position priors (" +
           CountOf(positions.size(), "image") + " with one, " +
           std::to_string(distinct.size()) +
           " distinct positions), and at least three that are not on one "
           "line are needed";
  }

  const Eigen::Vector3d variances = PrincipalVariances(positions);
  const double spread_along_m = std::sqrt(variances(2));
  const double spread_across_m = std::sqrt(variances(0) + variances(1));
  const double std_m = options.prior_position_std_m;
  std::ostringstream text;
  text << std::setprecision(3);
  if (spread_along_m <= std_m) {
    text << "the position priors are nearly identical: they spread over "
         << spread_along_m << " m (RMS about their centre along their main "
         << "axis), no more than their standard deviation of " << std_m
         << " m (GlobalMapper.prior_position_std_m)";
    return text.str();
  }
  if (spread_across_m <= kCollinearRelativeSpread * spread_along_m) {
    text << "the position priors lie on one line (" << spread_across_m
         << " m RMS across it, " << spread_along_m
         << " m along it): the rotation about that line is not fixed";
    return text.str();
  }
  if (std::sqrt(variances(1)) <= std_m) {
    text << "The position priors lie nearly on one line: they spread by "
         << std::sqrt(variances(1)) << " m across it (RMS, second axis) and "
         << spread_along_m << " m along it, within their standard deviation "
         << "of " << std_m << " m (GlobalMapper.prior_position_std_m): the "
         << "rotation of the model about that line is fixed by little more "
            "than noise.";
    *nearly_collinear_warning = text.str();
  }
  return "";
}

}  // namespace

Status PositionPriorOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.GreaterThan("prior_position_std_m", prior_position_std_m, 0);
  check.GreaterThan("prior_loss_scale", prior_loss_scale, 0);
  check.GreaterThan("prior_max_error_std", prior_max_error_std, 0);
  return check.status();
}

std::string Georegistration::ToText() const {
  std::ostringstream text;
  if (!georegistered) {
    text << "# Frame of this model: arbitrary (no position priors were "
            "used)\n"
         << "frame arbitrary\n";
    return text.str();
  }
  text << "# Frame of this model: camera positions in metres from position "
          "priors\n";
  if (frame == "ENU") {
    text << "# x east, y north, z up, in metres from the origin (WGS84 "
            "latitude, longitude, ellipsoidal altitude); back to GPS with "
            "colmap::GPSTransform(WGS84).ENUToEll(xyz, lat, lon, alt)\n";
  } else if (frame == "ECEF") {
    text << "# earth-centred, earth-fixed (WGS84), in metres\n";
  } else {
    text << "# the frame of the priors as stored in the database "
            "(images.prior_tx, prior_ty, prior_tz), in metres\n";
  }
  text << "frame " << frame << "\n";
  if (frame == "ENU") {
    text << std::setprecision(17) << "origin_latitude_deg " << origin_lla.x()
         << "\norigin_longitude_deg " << origin_lla.y()
         << "\norigin_altitude_m " << origin_lla.z() << "\n";
  }
  text << "priors_used " << num_priors_used << "\n"
       << "priors_rejected " << rejected_prior_image_names.size() << "\n";
  if (std::isfinite(prior_noise_estimate_m)) {
    text << std::setprecision(3) << "prior_noise_estimate_m "
         << prior_noise_estimate_m << "\n";
  }
  for (const std::string& name : rejected_prior_image_names) {
    text << "rejected_prior_image " << name << "\n";
  }
  return text.str();
}

Eigen::Vector3d PrincipalVariances(
    const std::vector<Eigen::Vector3d>& positions) {
  if (positions.empty()) return Eigen::Vector3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : positions) mean += p;
  mean /= static_cast<double>(positions.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : positions) {
    covariance += (p - mean) * (p - mean).transpose();
  }
  covariance /= static_cast<double>(positions.size());
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance,
                                                        Eigen::EigenvaluesOnly)
      .eigenvalues()
      .cwiseMax(0);
}

Status PreparePositionPriors(const PositionPriorOptions& options,
                             const colmap::Reconstruction& reconstruction,
                             PositionPriors* priors) {
  *priors = PositionPriors();
  std::vector<colmap::image_t> image_ids;
  image_ids.reserve(reconstruction.NumImages());
  for (const auto& [image_id, image] : reconstruction.Images()) {
    image_ids.push_back(image_id);
  }
  std::sort(image_ids.begin(), image_ids.end());

  // Set priors: any coordinate not NaN (COLMAP stores an unset prior as
  // NULL, read as NaN in every coordinate).
  std::vector<colmap::image_t> prior_image_ids;
  std::vector<Eigen::Vector3d> values;
  size_t num_non_finite = 0;
  const colmap::Image* first_non_finite = nullptr;
  for (const colmap::image_t image_id : image_ids) {
    const colmap::Image& image = reconstruction.Image(image_id);
    const Eigen::Vector3d& prior = image.TvecPrior();
    if (prior.array().isNaN().all()) continue;
    if (!prior.allFinite()) {
      if (num_non_finite++ == 0) first_non_finite = &image;
      continue;
    }
    prior_image_ids.push_back(image_id);
    values.push_back(prior);
  }
  const size_t num_set = prior_image_ids.size() + num_non_finite;
  if (num_set == 0) {
    if (options.use_position_priors) {
      LOG(WARNING) << "GlobalMapper.use_position_priors is set, but no image "
                      "has a position prior: solving without priors.";
    }
    return Status::Ok();
  }
  if (!options.use_position_priors) {
    LOG(INFO) << CountOf(num_set, "image") << (num_set == 1 ? " has" : " have")
              << " position priors; set --GlobalMapper.use_position_priors 1 "
                 "to use them.";
    return Status::Ok();
  }

  if (options.prior_is_gps) {
    size_t num_outside = 0;
    size_t first_outside = 0;
    for (size_t i = 0; i < values.size(); ++i) {
      if (!IsLatitudeLongitude(values[i]) && num_outside++ == 0) {
        first_outside = i;
      }
    }
    if (num_outside > 0) {
      const colmap::Image& image =
          reconstruction.Image(prior_image_ids[first_outside]);
      std::string others;
      if (num_outside > 1) {
        others = " (and " + std::to_string(num_outside - 1) + " other " +
                 (num_outside == 2 ? "image" : "images") + ")";
      }
      return Status::Error(
          "The position prior of " + ImageText(image) + others + " is " +
          PriorText(values[first_outside]) +
          ", which is no latitude in [-90, 90] and longitude in [-180, 180] "
          "deg: GlobalMapper.prior_is_gps is set, but the priors look like "
          "metric values: set GlobalMapper.prior_is_gps 0");
    }
  } else if (options.prior_use_ecef) {
    LOG(WARNING) << "GlobalMapper.prior_use_ecef has no effect without "
                    "GlobalMapper.prior_is_gps: the priors are used as "
                    "metric values.";
  }

  if (num_non_finite > 0) {
    LOG(WARNING) << CountOf(num_non_finite, "image")
                 << (num_non_finite == 1 ? " has" : " have")
                 << " a position prior that is not finite (NaN or infinite "
                    "in a coordinate; first: "
                 << ImageText(*first_non_finite) << ", "
                 << PriorText(first_non_finite->TvecPrior())
                 << "): left out, as images without a prior.";
  }
  if (values.empty()) {
    LOG(WARNING) << "No image has a finite position prior: solving without "
                    "priors.";
    return Status::Ok();
  }

  Georegistration georegistration;
  const std::vector<Eigen::Vector3d> positions =
      ConvertToFrame(options, values, &georegistration);
  std::string nearly_collinear_warning;
  const std::string degeneracy =
      Degeneracy(options, positions, &nearly_collinear_warning);
  if (!degeneracy.empty()) {
    std::string hint;
    if (!options.prior_is_gps &&
        std::all_of(values.begin(), values.end(), IsLatitudeLongitude)) {
      hint =
          " (if they are latitudes and longitudes, set "
          "GlobalMapper.prior_is_gps 1)";
    }
    LOG(WARNING) << "Position priors not used: " << degeneracy << hint
                 << "; a similarity transformation of the model is not "
                    "fixed by them, so the model is solved without priors, "
                    "in an arbitrary frame.";
    return Status::Ok();
  }
  if (!nearly_collinear_warning.empty()) {
    LOG(WARNING) << nearly_collinear_warning;
  }

  for (size_t i = 0; i < positions.size(); ++i) {
    priors->center_in_frame.emplace(prior_image_ids[i], positions[i]);
  }
  georegistration.georegistered = true;
  georegistration.num_priors_used = positions.size();
  priors->georegistration = std::move(georegistration);

  std::ostringstream frame;
  frame << priors->georegistration.frame;
  if (priors->georegistration.frame == "ENU") {
    const Eigen::Vector3d& origin = priors->georegistration.origin_lla;
    frame << std::setprecision(10) << " around latitude " << origin.x()
          << " deg, longitude " << origin.y() << " deg, altitude " << origin.z()
          << " m (the prior of "
          << ImageText(reconstruction.Image(prior_image_ids.front())) << ")";
  }
  LOG(INFO) << "Position priors: " << positions.size() << " of "
            << CountOf(image_ids.size(), "image")
            << " have one; solving in the frame " << frame.str() << ".";
  if (2 * positions.size() < image_ids.size()) {
    LOG(WARNING) << "Only " << positions.size() << " of "
                 << CountOf(image_ids.size(), "image")
                 << " have a usable position prior: the others are placed by "
                    "their matches alone.";
  }
  return Status::Ok();
}

}  // namespace glomap
