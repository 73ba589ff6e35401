#include "glomap/processors/track_establishment.h"

#include <gtest/gtest.h>

#include <vector>

#include "base/camera.h"
#include "base/image.h"

namespace glomap {
namespace {

// Images with hand-placed keypoints and a view graph of hand-made matches.
class TrackScene {
 public:
  TrackScene() {
    colmap::Camera camera;
    camera.SetCameraId(1);
    camera.InitializeWithName("SIMPLE_PINHOLE", 500, 1000, 1000);
    reconstruction.AddCamera(camera);
  }

  void AddImage(colmap::image_t image_id,
                const std::vector<Eigen::Vector2d>& keypoints,
                bool registered = true) {
    colmap::Image image;
    image.SetImageId(image_id);
    image.SetCameraId(1);
    image.SetName("image" + std::to_string(image_id));
    image.SetPoints2D(keypoints);
    reconstruction.AddImage(image);
    if (registered) reconstruction.RegisterImage(image_id);
  }

  // All matches are inliers unless listed in `outlier_match_idxs`.
  ImagePair& AddPair(colmap::image_t image_id1, colmap::image_t image_id2,
                     const std::vector<std::pair<int, int>>& matches,
                     const std::vector<int>& outlier_match_idxs = {}) {
    ImagePair pair;
    pair.image_id1 = image_id1;
    pair.image_id2 = image_id2;
    for (size_t i = 0; i < matches.size(); ++i) {
      pair.matches.emplace_back(matches[i].first, matches[i].second);
      if (std::find(outlier_match_idxs.begin(), outlier_match_idxs.end(),
                    static_cast<int>(i)) == outlier_match_idxs.end()) {
        pair.inlier_idxs.push_back(i);
      }
    }
    return view_graph.AddPair(pair);
  }

  colmap::Reconstruction reconstruction;
  ViewGraph view_graph;
};

std::vector<std::pair<colmap::image_t, colmap::point2D_t>> Track(
    const TrackStore& tracks, size_t idx) {
  std::vector<std::pair<colmap::image_t, colmap::point2D_t>> track;
  for (const TrackObservation* obs = tracks.TrackBegin(idx);
       obs != tracks.TrackEnd(idx); ++obs) {
    track.emplace_back(obs->image_id, obs->point2D_idx);
  }
  return track;
}

using Obs = std::pair<colmap::image_t, colmap::point2D_t>;

std::vector<Eigen::Vector2d> Keypoints(int n) {
  std::vector<Eigen::Vector2d> keypoints;
  for (int i = 0; i < n; ++i) keypoints.emplace_back(100 * i, 100 * i);
  return keypoints;
}

TEST(TrackEstablishment, ChainsMatchesIntoTracksLongestFirst) {
  TrackScene scene;
  for (colmap::image_t id = 1; id <= 4; ++id) scene.AddImage(id, Keypoints(4));
  // Track A: (1,0)-(2,1)-(3,2)-(4,3) through a chain of pairs, given in
  // reversed orientation for one pair. Track B: (1,1)-(2,0)-(3,0).
  // Track C: (1,2)-(2,2), length 2, dropped.
  scene.AddPair(1, 2, {{0, 1}, {1, 0}, {2, 2}});
  scene.AddPair(3, 2, {{2, 1}, {0, 0}});
  scene.AddPair(3, 4, {{2, 3}});
  TrackEstablishmentOptions options;
  options.min_num_tracks_per_view = -1;
  size_t num_inconsistent = 99;
  const TrackStore tracks = EstablishTracks(
      options, scene.view_graph, scene.reconstruction, &num_inconsistent);
  EXPECT_EQ(num_inconsistent, 0);
  ASSERT_EQ(tracks.NumTracks(), 2);
  EXPECT_EQ(Track(tracks, 0),
            (std::vector<Obs>{{1, 0}, {2, 1}, {3, 2}, {4, 3}}));
  EXPECT_EQ(Track(tracks, 1), (std::vector<Obs>{{1, 1}, {2, 0}, {3, 0}}));

  options.min_num_views_per_track = 2;
  options.max_num_views_per_track = 3;
  const TrackStore short_tracks =
      EstablishTracks(options, scene.view_graph, scene.reconstruction);
  ASSERT_EQ(short_tracks.NumTracks(), 2);
  EXPECT_EQ(Track(short_tracks, 0), (std::vector<Obs>{{1, 1}, {2, 0}, {3, 0}}));
  EXPECT_EQ(Track(short_tracks, 1), (std::vector<Obs>{{1, 2}, {2, 2}}));

  options.max_num_tracks = 1;
  EXPECT_EQ(EstablishTracks(options, scene.view_graph, scene.reconstruction)
                .NumTracks(),
            1);
}

TEST(TrackEstablishment, OnlyInliersOfValidPairsBetweenRegisteredImages) {
  TrackScene scene;
  for (colmap::image_t id = 1; id <= 3; ++id) scene.AddImage(id, Keypoints(3));
  scene.AddImage(4, Keypoints(3), /*registered=*/false);
  scene.AddImage(5, Keypoints(3));
  // (1,0)-(2,0)-(3,0) is a track; the outlier match (1,1)-(2,1), the invalid
  // pair's match and the unregistered image's match add nothing to it.
  scene.AddPair(1, 2, {{0, 0}, {1, 1}}, /*outlier_match_idxs=*/{1});
  scene.AddPair(2, 3, {{0, 0}, {1, 1}});
  scene.AddPair(1, 5, {{0, 0}}).is_valid = false;
  scene.AddPair(3, 4, {{0, 0}});
  // Keypoint index out of range: ignored, not a crash.
  scene.AddPair(1, 3, {{2, 7}});
  TrackEstablishmentOptions options;
  options.min_num_views_per_track = 2;
  const TrackStore tracks =
      EstablishTracks(options, scene.view_graph, scene.reconstruction);
  ASSERT_EQ(tracks.NumTracks(), 2);
  EXPECT_EQ(Track(tracks, 0), (std::vector<Obs>{{1, 0}, {2, 0}, {3, 0}}));
  EXPECT_EQ(Track(tracks, 1), (std::vector<Obs>{{2, 1}, {3, 1}}));
}

TEST(TrackEstablishment, TwoFeaturesInOneImage) {
  TrackScene scene;
  // Image 1: keypoints 0 and 1 are 5 px apart, 2 and 3 are 516 px apart.
  scene.AddImage(1, {{100, 100}, {103, 104}, {130, 140}, {500, 500}});
  scene.AddImage(2, Keypoints(4));
  scene.AddImage(3, Keypoints(4));
  // Close duplicates: (1,0)-(2,0)-(3,0)-(1,1) keeps (1,0).
  scene.AddPair(1, 2, {{0, 0}, {2, 1}});
  scene.AddPair(2, 3, {{0, 0}, {1, 1}});
  scene.AddPair(1, 3, {{1, 0}, {3, 1}});
  // Far duplicates: (1,2)-(2,1)-(3,1)-(1,3) is inconsistent and dropped.
  TrackEstablishmentOptions options;
  size_t num_inconsistent = 0;
  const TrackStore tracks = EstablishTracks(
      options, scene.view_graph, scene.reconstruction, &num_inconsistent);
  EXPECT_EQ(num_inconsistent, 1);
  ASSERT_EQ(tracks.NumTracks(), 1);
  EXPECT_EQ(Track(tracks, 0), (std::vector<Obs>{{1, 0}, {2, 0}, {3, 0}}));

  // A looser limit keeps the far track too (first observation per image).
  options.max_intra_image_distance_px = 1000;
  const TrackStore loose = EstablishTracks(
      options, scene.view_graph, scene.reconstruction, &num_inconsistent);
  EXPECT_EQ(num_inconsistent, 0);
  ASSERT_EQ(loose.NumTracks(), 2);
  EXPECT_EQ(Track(loose, 1), (std::vector<Obs>{{1, 2}, {2, 1}, {3, 1}}));
}

TEST(TrackEstablishment, PerImageQuotaTakesLongestTracksFirst) {
  // Images 1..4, each feature k matched across all images, so every track
  // has length 4 except track k=0 which misses image 4; plus tracks only in
  // images 3-4-5.
  TrackScene scene;
  const int n = 10;
  for (colmap::image_t id = 1; id <= 5; ++id)
    scene.AddImage(id, Keypoints(2 * n));
  std::vector<std::pair<int, int>> identity, identity_without_first, upper;
  for (int k = 0; k < n; ++k) {
    identity.emplace_back(k, k);
    if (k > 0) identity_without_first.emplace_back(k, k);
    upper.emplace_back(n + k, n + k);
  }
  scene.AddPair(1, 2, identity);
  scene.AddPair(2, 3, identity);
  scene.AddPair(3, 4, [&] {
    auto matches = identity_without_first;
    matches.insert(matches.end(), upper.begin(), upper.end());
    return matches;
  }());
  scene.AddPair(4, 5, upper);
  TrackEstablishmentOptions options;
  options.min_num_tracks_per_view = -1;
  const TrackStore all =
      EstablishTracks(options, scene.view_graph, scene.reconstruction);
  // 9 tracks of length 4, 1 of length 3 (k=0: 1-2-3), 10 of length 3 (3-4-5).
  ASSERT_EQ(all.NumTracks(), 20);
  EXPECT_EQ(all.TrackLength(0), 4);
  EXPECT_EQ(all.TrackLength(8), 4);
  EXPECT_EQ(all.TrackLength(9), 3);

  // Quota 2: two long tracks satisfy images 1-4; image 5 needs two of the
  // 3-4-5 tracks; the rest is not needed.
  options.min_num_tracks_per_view = 2;
  const TrackStore quota =
      EstablishTracks(options, scene.view_graph, scene.reconstruction);
  ASSERT_EQ(quota.NumTracks(), 4);
  EXPECT_EQ(quota.TrackLength(0), 4);
  EXPECT_EQ(quota.TrackLength(1), 4);
  EXPECT_EQ(Track(quota, 2).back(), (Obs{5, n}));
  EXPECT_EQ(Track(quota, 3).back(), (Obs{5, n + 1}));

  options.min_num_tracks_per_view = 0;
  EXPECT_EQ(options.Check().message(),
            "min_num_tracks_per_view must be -1 or >= 1, is 0");
  EXPECT_EQ(EstablishTracks(options, scene.view_graph, scene.reconstruction)
                .NumTracks(),
            0);
}

}  // namespace
}  // namespace glomap
