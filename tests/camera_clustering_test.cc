#include "glomap/processors/camera_clustering.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "base/reconstruction.h"

namespace glomap {
namespace {

using ImageIds = std::vector<colmap::image_t>;

// Builds reconstructions from tracks only (clustering looks at covisibility,
// not geometry).
class SceneBuilder {
 public:
  explicit SceneBuilder(const ImageIds& image_ids) {
    colmap::Camera camera;
    camera.SetCameraId(1);
    camera.InitializeWithName("SIMPLE_PINHOLE", 500, 640, 480);
    reconstruction_.AddCamera(camera);
    for (const colmap::image_t image_id : image_ids) {
      colmap::Image image;
      image.SetImageId(image_id);
      image.SetName("image" + std::to_string(image_id));
      image.SetCameraId(1);
      image.SetPoints2D(
          std::vector<Eigen::Vector2d>(5000, Eigen::Vector2d(1, 1)));
      reconstruction_.AddImage(image);
      reconstruction_.RegisterImage(image_id);
    }
  }

  void AddPoint(const ImageIds& image_ids) {
    colmap::Track track;
    for (const colmap::image_t image_id : image_ids) {
      track.AddElement(image_id, next_idx_[image_id]++);
    }
    reconstruction_.AddPoint3D(Eigen::Vector3d::Zero(), track);
  }

  // `count` points seen by exactly the two images.
  void AddPairPoints(colmap::image_t image_id1, colmap::image_t image_id2,
                     int count) {
    for (int i = 0; i < count; ++i) AddPoint({image_id1, image_id2});
  }

  // `count` points, each seen by 3 to 5 random images of `group`.
  void AddGroupPoints(const ImageIds& group, int count, std::mt19937* rng) {
    for (int i = 0; i < count; ++i) {
      ImageIds shuffled = group;
      std::shuffle(shuffled.begin(), shuffled.end(), *rng);
      const size_t length = 3 + (*rng)() % 3;
      shuffled.resize(std::min(length, shuffled.size()));
      AddPoint(shuffled);
    }
  }

  colmap::Reconstruction& reconstruction() { return reconstruction_; }

 private:
  colmap::Reconstruction reconstruction_;
  std::map<colmap::image_t, colmap::point2D_t> next_idx_;
};

ImageIds Range(colmap::image_t first, colmap::image_t last) {
  ImageIds ids;
  for (colmap::image_t id = first; id <= last; ++id) ids.push_back(id);
  return ids;
}

// Two dense groups of 6 images; a few points glue image 3 to image 9 and
// images 2-8 and 4-10 (like wrongly matched internet photos).
colmap::Reconstruction TwoGroupsWithWeakLinks(int seed) {
  std::mt19937 rng(seed);
  SceneBuilder builder(Range(1, 12));
  builder.AddGroupPoints(Range(1, 6), 300, &rng);
  builder.AddGroupPoints(Range(7, 12), 300, &rng);
  builder.AddPairPoints(3, 9, 12);
  builder.AddPairPoints(2, 8, 8);
  builder.AddPairPoints(4, 10, 8);
  return builder.reconstruction();
}

TEST(CameraClustering, TwoGroupsJoinedByWeakLinksSplit) {
  const colmap::Reconstruction reconstruction = TwoGroupsWithWeakLinks(1);
  const auto clusters =
      ClusterCameras(CameraClusteringOptions(), reconstruction);
  ASSERT_EQ(clusters.size(), 2u);
  EXPECT_EQ(clusters[0], Range(1, 6));
  EXPECT_EQ(clusters[1], Range(7, 12));
}

TEST(CameraClustering, OneDenseGroupStaysTogether) {
  std::mt19937 rng(2);
  SceneBuilder builder(Range(1, 10));
  builder.AddGroupPoints(Range(1, 10), 600, &rng);
  const auto clusters =
      ClusterCameras(CameraClusteringOptions(), builder.reconstruction());
  ASSERT_EQ(clusters.size(), 1u);
  EXPECT_EQ(clusters[0], Range(1, 10));
}

TEST(CameraClustering, UniformWeightsStayTogether) {
  // Every pair shares exactly 100 points: median - MAD = 100, and edges at
  // the threshold must count as strong.
  SceneBuilder builder(Range(1, 5));
  for (colmap::image_t i = 1; i <= 5; ++i) {
    for (colmap::image_t j = i + 1; j <= 5; ++j) {
      builder.AddPairPoints(i, j, 100);
    }
  }
  const auto clusters =
      ClusterCameras(CameraClusteringOptions(), builder.reconstruction());
  ASSERT_EQ(clusters.size(), 1u);
  EXPECT_EQ(clusters[0], Range(1, 5));
}

// Groups {1..4} and {5..8}, each pair within a group sharing 100 points
// (tau = 100); cross edges of weight 80 (>= 0.75 tau) and 50 (< 0.75 tau).
colmap::Reconstruction TwoCliques(const std::vector<int>& cross_weights) {
  SceneBuilder builder(Range(1, 8));
  for (colmap::image_t offset : {0, 4}) {
    for (colmap::image_t i = 1; i <= 4; ++i) {
      for (colmap::image_t j = i + 1; j <= 4; ++j) {
        builder.AddPairPoints(offset + i, offset + j, 100);
      }
    }
  }
  for (size_t k = 0; k < cross_weights.size(); ++k) {
    builder.AddPairPoints(1 + k, 5 + k, cross_weights[k]);
  }
  return builder.reconstruction();
}

TEST(CameraClustering, MergesClustersLinkedByTwoModerateEdges) {
  const auto merged =
      ClusterCameras(CameraClusteringOptions(), TwoCliques({80, 80}));
  ASSERT_EQ(merged.size(), 1u);
  EXPECT_EQ(merged[0], Range(1, 8));

  // One moderate edge is not enough, nor one moderate plus one weak.
  for (const std::vector<int>& weights :
       {std::vector<int>{80}, std::vector<int>{80, 50}}) {
    const auto split =
        ClusterCameras(CameraClusteringOptions(), TwoCliques(weights));
    ASSERT_EQ(split.size(), 2u);
    EXPECT_EQ(split[0], Range(1, 4));  // Equal sizes: smallest id first.
    EXPECT_EQ(split[1], Range(5, 8));
  }

  // Merging can be switched off.
  CameraClusteringOptions no_merge;
  no_merge.max_merge_rounds = 0;
  EXPECT_EQ(ClusterCameras(no_merge, TwoCliques({80, 80})).size(), 2u);
}

TEST(CameraClustering, OrderAndMinClusterSize) {
  SceneBuilder builder({1, 2, 3, 10, 11, 12, 13, 20});
  for (const ImageIds& group : {ImageIds{10, 11, 12, 13}, ImageIds{1, 2, 3}}) {
    for (size_t i = 0; i < group.size(); ++i) {
      for (size_t j = i + 1; j < group.size(); ++j) {
        builder.AddPairPoints(group[i], group[j], 50);
      }
    }
  }
  // Image 20 shares only 3 points (below min_covisible_points) with image 1.
  builder.AddPairPoints(1, 20, 3);
  const auto clusters =
      ClusterCameras(CameraClusteringOptions(), builder.reconstruction());
  ASSERT_EQ(clusters.size(), 2u);  // The singleton {20} is dropped.
  EXPECT_EQ(clusters[0], (ImageIds{10, 11, 12, 13}));  // Largest first.
  EXPECT_EQ(clusters[1], (ImageIds{1, 2, 3}));

  CameraClusteringOptions keep_singletons;
  keep_singletons.min_cluster_size = 1;
  const auto all = ClusterCameras(keep_singletons, builder.reconstruction());
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[2], ImageIds{20});

  CameraClusteringOptions bad;
  bad.min_cluster_size = 0;
  EXPECT_EQ(bad.Check().message(), "min_cluster_size must be >= 1, is 0");
  EXPECT_TRUE(ClusterCameras(bad, builder.reconstruction()).empty());
}

TEST(CameraClustering, Deterministic) {
  for (int seed = 3; seed < 6; ++seed) {
    EXPECT_EQ(ClusterCameras({}, TwoGroupsWithWeakLinks(seed)),
              ClusterCameras({}, TwoGroupsWithWeakLinks(seed)));
  }
}

TEST(CameraClustering, ExtractClusterKeepsOnlyClusterObservations) {
  const colmap::Reconstruction reconstruction = TwoGroupsWithWeakLinks(7);
  const ImageIds cluster_ids = Range(7, 12);
  const std::set<colmap::image_t> cluster_set(cluster_ids.begin(),
                                              cluster_ids.end());
  size_t expected_points = 0;
  for (const auto& point3D : reconstruction.Points3D()) {
    size_t num_in_cluster = 0;
    for (const auto& el : point3D.second.Track().Elements()) {
      num_in_cluster += cluster_set.count(el.image_id);
    }
    expected_points += num_in_cluster >= 2;
  }
  const colmap::Reconstruction cluster =
      ExtractCluster(reconstruction, cluster_ids);
  // Only the cluster's images are copied, all registered.
  EXPECT_EQ(cluster.NumImages(), cluster_ids.size());
  EXPECT_EQ(cluster.NumCameras(), 1u);
  ImageIds registered = cluster.RegImageIds();
  std::sort(registered.begin(), registered.end());
  EXPECT_EQ(registered, cluster_ids);
  EXPECT_EQ(cluster.NumPoints3D(), expected_points);
  for (const auto& point3D : cluster.Points3D()) {
    EXPECT_GE(point3D.second.Track().Length(), 2u);
    for (const auto& el : point3D.second.Track().Elements()) {
      EXPECT_EQ(cluster_set.count(el.image_id), 1u);
    }
  }
  for (colmap::image_t image_id = 1; image_id <= 6; ++image_id) {
    EXPECT_FALSE(cluster.ExistsImage(image_id));
  }
  // The input is untouched.
  EXPECT_EQ(reconstruction.NumRegImages(), 12u);
}

// Values and links of an extracted cluster: cameras of other images are not
// copied; images keep name, camera, pose and keypoints; each point keeps
// its position, colour, error and its cluster observations in their order,
// and each of those keypoints links back to it. Unregistered images and ids
// that do not exist are not taken.
TEST(CameraClustering, ExtractClusterCopiesExactlyTheCluster) {
  colmap::Reconstruction reconstruction;
  for (const colmap::camera_t camera_id : {1, 2, 3}) {
    colmap::Camera camera;
    camera.SetCameraId(camera_id);
    camera.InitializeWithName("SIMPLE_RADIAL", 400 + 100 * camera_id, 640, 480);
    reconstruction.AddCamera(camera);
  }
  // Images 1-4 use cameras 1 and 2, images 5-6 camera 3; image 7 (camera 3)
  // stays unregistered.
  for (colmap::image_t image_id = 1; image_id <= 7; ++image_id) {
    colmap::Image image;
    image.SetImageId(image_id);
    image.SetName("image" + std::to_string(image_id));
    image.SetCameraId(image_id <= 2 ? 1 : image_id <= 4 ? 2 : 3);
    image.SetQvec(Eigen::Vector4d(1, 0.1 * image_id, 0, 0).normalized());
    image.SetTvec(Eigen::Vector3d(image_id, -1, 2));
    std::vector<Eigen::Vector2d> keypoints;
    for (int k = 0; k < 20; ++k) {
      keypoints.emplace_back(10 * k + image_id, 5 * k);
    }
    image.SetPoints2D(keypoints);
    reconstruction.AddImage(image);
    if (image_id != 7) reconstruction.RegisterImage(image_id);
  }
  auto add_point = [&](const std::vector<colmap::TrackElement>& elements,
                       double x) {
    colmap::Track track;
    track.AddElements(elements);
    const colmap::point3D_t point3D_id = reconstruction.AddPoint3D(
        Eigen::Vector3d(x, 2 * x, 3), track,
        Eigen::Vector3ub(static_cast<uint8_t>(x), 7, 9));
    reconstruction.Point3D(point3D_id).SetError(0.1 * x);
    return point3D_id;
  };
  // Observations in mixed order, some outside the cluster {4, 3, 1, 2}.
  const colmap::point3D_t kept1 = add_point({{4, 0}, {5, 0}, {1, 3}}, 1);
  add_point({{5, 1}, {6, 1}}, 2);  // Outside: dropped.
  add_point({{2, 2}, {6, 2}}, 3);  // One left: dropped.
  const colmap::point3D_t kept2 = add_point({{3, 4}, {2, 4}, {1, 4}}, 4);
  add_point({{1, 5}, {5, 5}, {6, 5}}, 5);  // One left: dropped.

  const colmap::Reconstruction cluster =
      ExtractCluster(reconstruction, {4, 3, 1, 2, 7, 99});
  ImageIds registered = cluster.RegImageIds();
  std::sort(registered.begin(), registered.end());
  EXPECT_EQ(registered, (ImageIds{1, 2, 3, 4}));
  EXPECT_EQ(cluster.NumImages(), 4u);
  ASSERT_EQ(cluster.NumCameras(), 2u);
  for (const colmap::camera_t camera_id : {1, 2}) {
    EXPECT_EQ(cluster.Camera(camera_id).Params(),
              reconstruction.Camera(camera_id).Params());
  }
  for (const colmap::image_t image_id : registered) {
    const colmap::Image& image = cluster.Image(image_id);
    const colmap::Image& source = reconstruction.Image(image_id);
    EXPECT_EQ(image.Name(), source.Name());
    EXPECT_EQ(image.CameraId(), source.CameraId());
    EXPECT_EQ(image.Qvec(), source.Qvec());
    EXPECT_EQ(image.Tvec(), source.Tvec());
    ASSERT_EQ(image.NumPoints2D(), source.NumPoints2D());
    for (colmap::point2D_t idx = 0; idx < image.NumPoints2D(); ++idx) {
      EXPECT_EQ(image.Point2D(idx).XY(), source.Point2D(idx).XY());
    }
  }

  // Kept points in the order of their old ids, with new ids.
  ASSERT_EQ(cluster.NumPoints3D(), 2u);
  std::vector<colmap::point3D_t> ids;
  for (const auto& point3D : cluster.Points3D()) ids.push_back(point3D.first);
  std::sort(ids.begin(), ids.end());
  const std::vector<std::pair<colmap::point3D_t, std::vector<colmap::image_t>>>
      expected = {{kept1, {4, 1}}, {kept2, {3, 2, 1}}};
  size_t num_observations = 0;
  for (size_t i = 0; i < expected.size(); ++i) {
    const colmap::Point3D& point3D = cluster.Point3D(ids[i]);
    const colmap::Point3D& source = reconstruction.Point3D(expected[i].first);
    EXPECT_EQ(point3D.XYZ(), source.XYZ());
    EXPECT_EQ(point3D.Color(), source.Color());
    EXPECT_EQ(point3D.Error(), source.Error());
    ImageIds observers;
    for (const colmap::TrackElement& el : point3D.Track().Elements()) {
      observers.push_back(el.image_id);
      EXPECT_EQ(cluster.Image(el.image_id).Point2D(el.point2D_idx).Point3DId(),
                ids[i]);
    }
    EXPECT_EQ(observers, expected[i].second);
    num_observations += observers.size();
  }
  // No keypoint links to a point that was not kept.
  size_t num_linked = 0;
  for (const colmap::image_t image_id : registered) {
    num_linked += cluster.Image(image_id).NumPoints3D();
  }
  EXPECT_EQ(num_linked, num_observations);
  EXPECT_EQ(cluster.ComputeNumObservations(), num_observations);
}

}  // namespace
}  // namespace glomap
