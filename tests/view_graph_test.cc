#include "glomap/scene/view_graph.h"

#include <gtest/gtest.h>

#include <vector>

#include "glomap/scene/tracks.h"

namespace glomap {
namespace {

ImagePair MakePair(colmap::image_t image_id1, colmap::image_t image_id2,
                   int num_matches) {
  ImagePair pair;
  pair.image_id1 = image_id1;
  pair.image_id2 = image_id2;
  for (int i = 0; i < num_matches; ++i) {
    pair.matches.emplace_back(i, i + 1);
    if (i % 2 == 0) pair.inlier_idxs.push_back(i);
  }
  pair.qvec2_from_1 = Eigen::Vector4d(0, 1, 0, 0);
  pair.has_relative_pose = true;
  return pair;
}

// Releasing the inlier indices frees them in every pair, valid or not, and
// leaves everything else of the pair as it was.
TEST(ViewGraph, ReleaseInlierIdxsKeepsTheRest) {
  ViewGraph view_graph;
  view_graph.AddPair(MakePair(1, 2, 40));
  view_graph.AddPair(MakePair(2, 3, 30)).is_valid = false;
  const ViewGraph before = view_graph;
  view_graph.ReleaseInlierIdxs();
  ASSERT_EQ(view_graph.NumPairs(), 2u);
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    const ImagePair& old = before.Pairs().at(pair_id);
    EXPECT_FALSE(old.inlier_idxs.empty());
    EXPECT_TRUE(pair.inlier_idxs.empty());
    EXPECT_EQ(pair.inlier_idxs.capacity(), 0u);
    ASSERT_EQ(pair.matches.size(), old.matches.size());
    for (size_t i = 0; i < pair.matches.size(); ++i) {
      EXPECT_EQ(pair.matches[i].point2D_idx1, old.matches[i].point2D_idx1);
      EXPECT_EQ(pair.matches[i].point2D_idx2, old.matches[i].point2D_idx2);
    }
    EXPECT_EQ(pair.is_valid, old.is_valid);
    EXPECT_EQ(pair.has_relative_pose, old.has_relative_pose);
    EXPECT_EQ(pair.qvec2_from_1, old.qvec2_from_1);
  }
  EXPECT_EQ(view_graph.NumValidPairs(), 1u);
}

// A cleared track store is empty and can be filled again.
TEST(TrackStore, ClearEmptiesAndCanRefill) {
  TrackStore tracks;
  tracks.AddTrack({{1, 0}, {2, 5}, {3, 7}});
  tracks.AddTrack({{1, 1}, {4, 2}});
  ASSERT_EQ(tracks.NumTracks(), 2u);
  tracks.Clear();
  EXPECT_EQ(tracks.NumTracks(), 0u);
  EXPECT_EQ(tracks.NumObservations(), 0u);
  EXPECT_EQ(tracks.AddTrack({{5, 3}, {6, 4}}), 0u);
  ASSERT_EQ(tracks.NumTracks(), 1u);
  EXPECT_EQ(tracks.TrackLength(0), 2u);
  EXPECT_EQ(tracks.TrackBegin(0)->image_id, 5u);
  EXPECT_EQ((tracks.TrackEnd(0) - 1)->point2D_idx, 4u);
}

}  // namespace
}  // namespace glomap
