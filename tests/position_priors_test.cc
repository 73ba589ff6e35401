// Position priors in and out (issue 12): options, conversion of GPS into ENU
// or ECEF, metric priors as given, the errors and warnings on bad priors, and
// the georegistration.txt text. Synthetic reconstructions built by hand.
#include "glomap/priors/position_priors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <utility>
#include <vector>

#include "base/gps.h"
#include "base/reconstruction.h"

namespace glomap {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Zurich, as the synthetic scenes use it.
const Eigen::Vector3d kOriginLla(47.3769, 8.5417, 400);

std::string ImageName(colmap::image_t image_id) {
  return "image" + std::to_string(image_id) + ".png";
}

// A reconstruction whose images (ids as given; unregistered, as the
// database reader leaves them) have the given priors (NaN: unset).
colmap::Reconstruction MakeReconstruction(
    const std::vector<std::pair<colmap::image_t, Eigen::Vector3d>>& priors) {
  colmap::Reconstruction reconstruction;
  colmap::Camera camera;
  camera.SetCameraId(1);
  camera.InitializeWithName("SIMPLE_PINHOLE", 500, 640, 480);
  reconstruction.AddCamera(camera);
  for (const auto& [image_id, prior] : priors) {
    colmap::Image image;
    image.SetImageId(image_id);
    image.SetName(ImageName(image_id));
    image.SetCameraId(1);
    image.SetTvecPrior(prior);
    reconstruction.AddImage(image);
  }
  return reconstruction;
}

PositionPriorOptions UsePriors(bool is_gps = false) {
  PositionPriorOptions options;
  options.use_position_priors = true;
  options.prior_is_gps = is_gps;
  return options;
}

// PreparePositionPriors with what it logged.
Status Prepare(const PositionPriorOptions& options,
               const colmap::Reconstruction& reconstruction,
               PositionPriors* priors, std::string* log) {
  ::testing::internal::CaptureStderr();
  const Status status = PreparePositionPriors(options, reconstruction, priors);
  *log = ::testing::internal::GetCapturedStderr();
  return status;
}

// GPS of ENU positions around kOriginLla.
Eigen::Vector3d Lla(const Eigen::Vector3d& enu) {
  return colmap::GPSTransform(colmap::GPSTransform::WGS84)
      .ENUToEll({enu}, kOriginLla.x(), kOriginLla.y(), kOriginLla.z())
      .front();
}

TEST(PositionPriorOptions, CheckNamesFieldAndRange) {
  EXPECT_TRUE(PositionPriorOptions().Check("GlobalMapper.").ok());
  const struct {
    std::function<void(PositionPriorOptions*)> change;
    std::string message;
  } cases[] = {
      {[](PositionPriorOptions* o) { o->prior_position_std_m = 0; },
       "GlobalMapper.prior_position_std_m must be > 0, is 0"},
      {[](PositionPriorOptions* o) { o->prior_loss_scale = -1; },
       "GlobalMapper.prior_loss_scale must be > 0, is -1"},
      {[](PositionPriorOptions* o) { o->prior_max_error_std = kNaN; },
       "GlobalMapper.prior_max_error_std must be > 0, is nan"},
  };
  for (const auto& c : cases) {
    PositionPriorOptions options;
    c.change(&options);
    const Status status = options.Check("GlobalMapper.");
    ASSERT_FALSE(status.ok()) << c.message;
    EXPECT_EQ(status.message(), c.message);
  }
  PositionPriorOptions options;
  options.prior_loss_scale = 0;
  EXPECT_EQ(options.Check().message(), "prior_loss_scale must be > 0, is 0");
}

TEST(PositionPriors, MetricPriorsAsGiven) {
  const colmap::Reconstruction reconstruction =
      MakeReconstruction({{1, Eigen::Vector3d(10, 20, 30)},
                          {2, Eigen::Vector3d(110, 20, 30)},
                          {3, Eigen::Vector3d(10, 80, 31)},
                          {4, Eigen::Vector3d(kNaN, kNaN, kNaN)}});
  PositionPriors priors;
  std::string log;
  ASSERT_TRUE(Prepare(UsePriors(), reconstruction, &priors, &log).ok());
  ASSERT_EQ(priors.center_in_frame.size(), 3u) << log;
  EXPECT_EQ(priors.center_in_frame.at(2), Eigen::Vector3d(110, 20, 30));
  EXPECT_EQ(priors.center_in_frame.count(4), 0u);
  const Georegistration& geo = priors.georegistration;
  EXPECT_TRUE(geo.georegistered);
  EXPECT_EQ(geo.frame, "metric");
  EXPECT_EQ(geo.num_priors_used, 3u);
  EXPECT_TRUE(geo.rejected_prior_image_names.empty());
  EXPECT_NE(log.find("Position priors: 3 of 4 images have one"),
            std::string::npos)
      << log;
  // Three of four images: no warning about few priors.
  EXPECT_EQ(log.find("Only "), std::string::npos) << log;
}

// GPS into ENU around the prior of the smallest image id, whatever the
// order of the images: a point 100 m east comes out (100, 0, 0).
TEST(PositionPriors, GpsToEnuAroundFirstImage) {
  const std::vector<std::pair<colmap::image_t, Eigen::Vector3d>> enu = {
      {9, Eigen::Vector3d(30, 40, 10)},
      {2, Eigen::Vector3d(0, 0, 0)},
      {5, Eigen::Vector3d(100, 0, 0)},
      {7, Eigen::Vector3d(0, -250, 3)},
      {8, Eigen::Vector3d(-1000, 2000, -20)}};
  std::vector<std::pair<colmap::image_t, Eigen::Vector3d>> gps;
  for (const auto& [image_id, position] : enu) {
    gps.emplace_back(image_id, Lla(position));
  }
  const colmap::Reconstruction reconstruction = MakeReconstruction(gps);
  PositionPriors priors;
  std::string log;
  ASSERT_TRUE(Prepare(UsePriors(true), reconstruction, &priors, &log).ok())
      << log;
  ASSERT_EQ(priors.center_in_frame.size(), enu.size());
  for (const auto& [image_id, position] : enu) {
    EXPECT_LT((priors.center_in_frame.at(image_id) - position).norm(), 1e-3)
        << image_id << ": " << priors.center_in_frame.at(image_id).transpose();
  }
  const Eigen::Vector3d east = priors.center_in_frame.at(5);
  EXPECT_NEAR(east.x(), 100, 1e-3);
  EXPECT_NEAR(east.y(), 0, 1e-3);
  EXPECT_NEAR(east.z(), 0, 1e-3);
  const Georegistration& geo = priors.georegistration;
  EXPECT_TRUE(geo.georegistered);
  EXPECT_EQ(geo.frame, "ENU");
  EXPECT_LT((geo.origin_lla - Lla(Eigen::Vector3d::Zero())).norm(), 1e-12);
  EXPECT_NE(log.find("image2.png"), std::string::npos) << log;

  // Back to GPS from the written origin: the round trip closes.
  const Eigen::Vector3d lla =
      colmap::GPSTransform(colmap::GPSTransform::WGS84)
          .ENUToEll({priors.center_in_frame.at(8)}, geo.origin_lla.x(),
                    geo.origin_lla.y(), geo.origin_lla.z())
          .front();
  EXPECT_NEAR(lla.x(), gps.back().second.x(), 1e-9);
  EXPECT_NEAR(lla.y(), gps.back().second.y(), 1e-9);
  EXPECT_NEAR(lla.z(), gps.back().second.z(), 1e-3);
}

TEST(PositionPriors, GpsToEcef) {
  std::vector<std::pair<colmap::image_t, Eigen::Vector3d>> gps = {
      {1, Lla(Eigen::Vector3d(0, 0, 0))},
      {2, Lla(Eigen::Vector3d(50, 0, 0))},
      {3, Lla(Eigen::Vector3d(0, 50, 5))}};
  PositionPriorOptions options = UsePriors(true);
  options.prior_use_ecef = true;
  PositionPriors priors;
  std::string log;
  ASSERT_TRUE(Prepare(options, MakeReconstruction(gps), &priors, &log).ok());
  ASSERT_EQ(priors.center_in_frame.size(), 3u) << log;
  const colmap::GPSTransform transform(colmap::GPSTransform::WGS84);
  for (const auto& [image_id, lla] : gps) {
    EXPECT_LT((priors.center_in_frame.at(image_id) -
               transform.EllToXYZ({lla}).front())
                  .norm(),
              1e-6);
  }
  EXPECT_EQ(priors.georegistration.frame, "ECEF");
  // 50 m apart in ECEF as in ENU.
  EXPECT_NEAR(
      (priors.center_in_frame.at(2) - priors.center_in_frame.at(1)).norm(), 50,
      1e-3);
}

// Metric values read as GPS: one error line that names an image and says
// which option to change.
TEST(PositionPriors, MetricValuesAsGpsAreAnError) {
  const colmap::Reconstruction reconstruction =
      MakeReconstruction({{1, Eigen::Vector3d(10, 20, 30)},
                          {2, Eigen::Vector3d(45, 20, 30)},
                          {3, Eigen::Vector3d(123, 20, 30)},
                          {4, Eigen::Vector3d(10, 200, 30)}});
  PositionPriors priors;
  std::string log;
  const Status status = Prepare(UsePriors(true), reconstruction, &priors, &log);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.message(),
            "The position prior of image image3.png (id 3) (and 1 other "
            "image) is (123, 20, 30), which is no latitude in [-90, 90] and "
            "longitude in [-180, 180] deg: GlobalMapper.prior_is_gps is set, "
            "but the priors look like metric values: set "
            "GlobalMapper.prior_is_gps 0");
  EXPECT_EQ(status.message().find('\n'), std::string::npos);
  EXPECT_TRUE(priors.empty());
  // The same values as metric priors are fine.
  ASSERT_TRUE(Prepare(UsePriors(false), reconstruction, &priors, &log).ok());
  EXPECT_EQ(priors.center_in_frame.size(), 4u) << log;
}

TEST(PositionPriors, OffLeavesThemUnusedWithOneLine) {
  const colmap::Reconstruction reconstruction =
      MakeReconstruction({{1, Eigen::Vector3d(0, 0, 0)},
                          {2, Eigen::Vector3d(100, 0, 0)},
                          {3, Eigen::Vector3d(0, 100, 0)},
                          {4, Eigen::Vector3d(kNaN, kNaN, kNaN)}});
  PositionPriorOptions options;
  // Off, even with values no GPS can have: no error, they are not used.
  options.prior_is_gps = true;
  PositionPriors priors;
  std::string log;
  ASSERT_TRUE(Prepare(options, reconstruction, &priors, &log).ok());
  EXPECT_TRUE(priors.empty());
  EXPECT_FALSE(priors.georegistration.georegistered);
  EXPECT_NE(log.find("3 images have position priors; set "
                     "--GlobalMapper.use_position_priors 1 to use them."),
            std::string::npos)
      << log;
  // One line: nothing else about the priors.
  EXPECT_EQ(log.find("position prior"), log.rfind("position prior")) << log;

  // No priors at all: nothing said when off.
  const colmap::Reconstruction without =
      MakeReconstruction({{1, Eigen::Vector3d(kNaN, kNaN, kNaN)}});
  ASSERT_TRUE(Prepare(PositionPriorOptions(), without, &priors, &log).ok());
  EXPECT_TRUE(log.empty()) << log;
  ASSERT_TRUE(Prepare(UsePriors(), without, &priors, &log).ok());
  EXPECT_TRUE(priors.empty());
  EXPECT_NE(log.find("no image has a position prior"), std::string::npos)
      << log;
}

// Priors that cannot fix a similarity: the free solve, with a warning that
// says why.
TEST(PositionPriors, DegeneratePriorsGiveTheFreeSolve) {
  const struct {
    std::string name;
    std::vector<std::pair<colmap::image_t, Eigen::Vector3d>> priors;
    std::string warning;
  } cases[] = {
      {"two distinct",
       {{1, Eigen::Vector3d(0, 0, 0)},
        {2, Eigen::Vector3d(0, 0, 0)},
        {3, Eigen::Vector3d(100, 0, 0)},
        {4, Eigen::Vector3d(kNaN, kNaN, kNaN)}},
       "fewer than three distinct position priors (3 images with one, 2 "
       "distinct positions)"},
      {"only two priors",
       {{1, Eigen::Vector3d(0, 0, 0)}, {2, Eigen::Vector3d(100, 0, 0)}},
       "fewer than three distinct position priors (2 images with one, 2 "
       "distinct positions)"},
      {"identical",
       {{1, Eigen::Vector3d(5, 6, 7)},
        {2, Eigen::Vector3d(5, 6, 7)},
        {3, Eigen::Vector3d(5, 6, 7)},
        {4, Eigen::Vector3d(5, 6, 7)}},
       "all 4 position priors are identical"},
      {"nearly identical",
       {{1, Eigen::Vector3d(5, 6, 7)},
        {2, Eigen::Vector3d(5.3, 6, 7)},
        {3, Eigen::Vector3d(5, 6.2, 7)},
        {4, Eigen::Vector3d(5, 6, 7.1)}},
       "the position priors are nearly identical"},
      {"collinear",
       {{1, Eigen::Vector3d(0, 0, 0)},
        {2, Eigen::Vector3d(10, 20, 2)},
        {3, Eigen::Vector3d(25, 50, 5)},
        {4, Eigen::Vector3d(-40, -80, -8)}},
       "the position priors lie on one line"},
  };
  for (const auto& c : cases) {
    PositionPriors priors;
    std::string log;
    ASSERT_TRUE(
        Prepare(UsePriors(), MakeReconstruction(c.priors), &priors, &log).ok())
        << c.name;
    EXPECT_TRUE(priors.empty()) << c.name;
    EXPECT_FALSE(priors.georegistration.georegistered) << c.name;
    EXPECT_NE(log.find("Position priors not used: " + c.warning),
              std::string::npos)
        << c.name << ": " << log;
    EXPECT_NE(log.find("a similarity transformation of the model is not fixed"),
              std::string::npos)
        << c.name << ": " << log;
  }
}

// A straight track in GPS is collinear in ENU too (the earth's curvature
// bends it by far less than the tolerance).
TEST(PositionPriors, CollinearGpsTrack) {
  std::vector<std::pair<colmap::image_t, Eigen::Vector3d>> gps;
  for (int i = 0; i < 20; ++i) {
    gps.emplace_back(i + 1, kOriginLla + Eigen::Vector3d(i * 1e-4, 0, 0));
  }
  PositionPriors priors;
  std::string log;
  ASSERT_TRUE(
      Prepare(UsePriors(true), MakeReconstruction(gps), &priors, &log).ok());
  EXPECT_TRUE(priors.empty());
  EXPECT_NE(log.find("lie on one line"), std::string::npos) << log;
}

// Priors within noise of a line are used, with a warning.
TEST(PositionPriors, NearlyCollinearPriorsAreUsedWithAWarning) {
  std::vector<std::pair<colmap::image_t, Eigen::Vector3d>> track;
  for (int i = 0; i < 20; ++i) {
    track.emplace_back(i + 1, Eigen::Vector3d(10 * i, (i % 2) * 0.5, 0));
  }
  PositionPriors priors;
  std::string log;
  ASSERT_TRUE(
      Prepare(UsePriors(), MakeReconstruction(track), &priors, &log).ok());
  EXPECT_EQ(priors.center_in_frame.size(), 20u);
  EXPECT_NE(log.find("The position priors lie nearly on one line"),
            std::string::npos)
      << log;
}

// NaN or infinite in a coordinate: left out and counted; the rest is used.
TEST(PositionPriors, NonFinitePriorsAreLeftOutAndCounted) {
  const colmap::Reconstruction reconstruction =
      MakeReconstruction({{1, Eigen::Vector3d(0, 0, 0)},
                          {2, Eigen::Vector3d(100, 0, 0)},
                          {3, Eigen::Vector3d(0, 100, 0)},
                          {4, Eigen::Vector3d(kInf, 0, 0)},
                          {5, Eigen::Vector3d(1, kNaN, 2)},
                          {6, Eigen::Vector3d(50, 50, -kInf)},
                          {7, Eigen::Vector3d(kNaN, kNaN, kNaN)}});
  PositionPriors priors;
  std::string log;
  ASSERT_TRUE(Prepare(UsePriors(), reconstruction, &priors, &log).ok());
  EXPECT_EQ(priors.center_in_frame.size(), 3u);
  for (const colmap::image_t image_id : {4, 5, 6, 7}) {
    EXPECT_EQ(priors.center_in_frame.count(image_id), 0u) << image_id;
  }
  EXPECT_NE(log.find("3 images have a position prior that is not finite (NaN "
                     "or infinite in a coordinate; first: image image4.png "
                     "(id 4), (inf, 0, 0)): left out"),
            std::string::npos)
      << log;
  // 3 of 7 images: fewer than half.
  EXPECT_NE(log.find("Only 3 of 7 images have a usable position prior"),
            std::string::npos)
      << log;

  // Nothing finite is left: the free solve.
  const colmap::Reconstruction all_bad = MakeReconstruction(
      {{1, Eigen::Vector3d(kInf, 0, 0)}, {2, Eigen::Vector3d(0, kNaN, 0)}});
  ASSERT_TRUE(Prepare(UsePriors(true), all_bad, &priors, &log).ok());
  EXPECT_TRUE(priors.empty());
  EXPECT_NE(log.find("2 images have a position prior that is not finite"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("No image has a finite position prior"), std::string::npos)
      << log;
}

// Key-value lines of a georegistration.txt text (comments skipped).
std::map<std::string, std::string> Values(const std::string& text) {
  std::map<std::string, std::string> values;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.find(' ');
    values[line.substr(0, space)] = line.substr(space + 1);
  }
  return values;
}

TEST(Georegistration, ToText) {
  Georegistration geo;
  geo.georegistered = true;
  geo.frame = "ENU";
  geo.origin_lla = Eigen::Vector3d(47.376912345678901, -8.5417, 401.25);
  geo.num_priors_used = 18;
  geo.rejected_prior_image_names = {"a.jpg", "dir/b c.jpg"};
  const std::string text = geo.ToText();
  EXPECT_EQ(text.rfind("# Frame of this model: camera positions in metres "
                       "from position priors\n",
                       0),
            0u)
      << text;
  const std::map<std::string, std::string> values = Values(text);
  EXPECT_EQ(values.at("frame"), "ENU");
  // 17 significant digits: the origin reads back exactly.
  EXPECT_EQ(std::stod(values.at("origin_latitude_deg")), geo.origin_lla.x());
  EXPECT_EQ(std::stod(values.at("origin_longitude_deg")), geo.origin_lla.y());
  EXPECT_EQ(values.at("origin_altitude_m"), "401.25");
  EXPECT_EQ(values.at("priors_used"), "18");
  EXPECT_EQ(values.at("priors_rejected"), "2");
  EXPECT_NE(text.find("\nrejected_prior_image a.jpg\n"), std::string::npos);
  EXPECT_NE(text.find("\nrejected_prior_image dir/b c.jpg\n"),
            std::string::npos);

  // Unknown until the model is made: no line.
  EXPECT_EQ(values.count("prior_noise_estimate_m"), 0u);

  geo.frame = "metric";
  geo.rejected_prior_image_names.clear();
  geo.prior_noise_estimate_m = 2.54321;
  const std::map<std::string, std::string> metric = Values(geo.ToText());
  EXPECT_EQ(metric.at("frame"), "metric");
  EXPECT_EQ(metric.count("origin_latitude_deg"), 0u);
  EXPECT_EQ(metric.at("priors_rejected"), "0");
  EXPECT_EQ(metric.at("prior_noise_estimate_m"), "2.54");

  EXPECT_EQ(Values(Georegistration().ToText()).at("frame"), "arbitrary");
}

}  // namespace
}  // namespace glomap
