#include "glomap/processors/track_establishment.h"

#include <glog/logging.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <utility>
#include <vector>

#include "glomap/util/options_check.h"
#include "glomap/util/union_find.h"

namespace glomap {

Status TrackEstablishmentOptions::Check(const std::string& prefix) const {
  OptionChecker check(prefix);
  check.AtLeast("max_intra_image_distance_px", max_intra_image_distance_px, 0);
  check.AtLeast("min_num_views_per_track", min_num_views_per_track, 2);
  check.AtLeastField("max_num_views_per_track", max_num_views_per_track,
                     "min_num_views_per_track", min_num_views_per_track);
  check.AtLeast("max_num_tracks", max_num_tracks, 0);
  check.MinusOneOrAtLeast("min_num_tracks_per_view", min_num_tracks_per_view,
                          1);
  return check.status();
}

namespace {

// Dense feature indices: the offset of the image (registered images in id
// order) + point2D_idx, so that the union-find needs no hash map.
struct FeatureIndex {
  std::vector<colmap::image_t> image_ids;
  std::unordered_map<colmap::image_t, size_t> image_idx_of_id;
  // Image i's features are [feature_offsets[i], feature_offsets[i + 1]).
  std::vector<uint64_t> feature_offsets;

  explicit FeatureIndex(const colmap::Reconstruction& reconstruction)
      : image_ids(reconstruction.RegImageIds()) {
    std::sort(image_ids.begin(), image_ids.end());
    feature_offsets.assign(image_ids.size() + 1, 0);
    for (size_t i = 0; i < image_ids.size(); ++i) {
      image_idx_of_id[image_ids[i]] = i;
      feature_offsets[i + 1] =
          feature_offsets[i] + reconstruction.Image(image_ids[i]).NumPoints2D();
    }
  }
  uint64_t NumFeatures() const { return feature_offsets.back(); }
};

// (root, feature) for every feature in a valid pair's inlier match, sorted:
// each track lies contiguously, its features in (image id, point2D_idx)
// order. The root of a track is its smallest feature whatever order the
// pairs come in; uint32_t indices halve the memory of the per-keypoint
// arrays.
std::vector<std::pair<uint32_t, uint32_t>> JoinMatchedFeatures(
    const ViewGraph& view_graph, const FeatureIndex& index) {
  const uint32_t num_features = static_cast<uint32_t>(index.NumFeatures());
  const std::vector<uint64_t>& feature_offsets = index.feature_offsets;
  UnionFind<uint32_t> union_find(num_features);
  std::vector<uint8_t> is_matched(num_features, 0);
  for (const auto& [pair_id, pair] : view_graph.Pairs()) {
    if (!pair.is_valid) continue;
    const auto image_idx1 = index.image_idx_of_id.find(pair.image_id1);
    const auto image_idx2 = index.image_idx_of_id.find(pair.image_id2);
    if (image_idx1 == index.image_idx_of_id.end() ||
        image_idx2 == index.image_idx_of_id.end()) {
      continue;
    }
    const uint64_t offset1 = feature_offsets[image_idx1->second];
    const uint64_t num_points1 =
        feature_offsets[image_idx1->second + 1] - offset1;
    const uint64_t offset2 = feature_offsets[image_idx2->second];
    const uint64_t num_points2 =
        feature_offsets[image_idx2->second + 1] - offset2;
    for (const int match_idx : pair.inlier_idxs) {
      if (match_idx < 0 ||
          static_cast<size_t>(match_idx) >= pair.matches.size())
        continue;
      const colmap::FeatureMatch& match = pair.matches[match_idx];
      if (match.point2D_idx1 >= num_points1 ||
          match.point2D_idx2 >= num_points2) {
        continue;
      }
      const uint32_t feature1 =
          static_cast<uint32_t>(offset1 + match.point2D_idx1);
      const uint32_t feature2 =
          static_cast<uint32_t>(offset2 + match.point2D_idx2);
      is_matched[feature1] = 1;
      is_matched[feature2] = 1;
      union_find.Union(feature1, feature2);
    }
  }

  std::vector<std::pair<uint32_t, uint32_t>> root_and_feature;
  for (uint32_t feature = 0; feature < num_features; ++feature) {
    if (is_matched[feature]) {
      root_and_feature.emplace_back(union_find.Find(feature), feature);
    }
  }
  is_matched = std::vector<uint8_t>();
  std::sort(root_and_feature.begin(), root_and_feature.end());
  return root_and_feature;
}

// Candidate tracks (consistent, length within bounds) in flat arrays.
struct CandidateTracks {
  std::vector<TrackObservation> observations;
  // Candidate k's observations are [offsets[k], offsets[k + 1]).
  std::vector<uint64_t> offsets = {0};
  std::vector<size_t> image_idxs;  // Parallel to the observations.
  size_t num_inconsistent = 0;

  size_t NumTracks() const { return offsets.size() - 1; }
  uint64_t Length(size_t k) const { return offsets[k + 1] - offsets[k]; }
};

// The groups of `root_and_feature` whose features within one image lie
// within max_intra_image_distance_px of each other and that see
// [min_num_views_per_track, max_num_views_per_track] images.
CandidateTracks MakeCandidates(
    const TrackEstablishmentOptions& options,
    const colmap::Reconstruction& reconstruction, const FeatureIndex& index,
    const std::vector<std::pair<uint32_t, uint32_t>>& root_and_feature) {
  const std::vector<colmap::image_t>& image_ids = index.image_ids;
  const std::vector<uint64_t>& feature_offsets = index.feature_offsets;
  CandidateTracks candidates;
  std::vector<TrackObservation>& candidate_observations =
      candidates.observations;
  std::vector<size_t>& candidate_image_idxs = candidates.image_idxs;
  size_t& num_inconsistent = candidates.num_inconsistent;
  const double max_squared_distance_px =
      options.max_intra_image_distance_px * options.max_intra_image_distance_px;
  for (size_t begin = 0; begin < root_and_feature.size();) {
    size_t end = begin + 1;
    while (end < root_and_feature.size() &&
           root_and_feature[end].first == root_and_feature[begin].first) {
      ++end;
    }
    const size_t track_begin = candidate_observations.size();
    bool is_consistent = true;
    for (size_t i = begin; i < end && is_consistent;) {
      const uint32_t feature = root_and_feature[i].second;
      const size_t image_idx =
          std::upper_bound(feature_offsets.begin(), feature_offsets.end(),
                           feature) -
          feature_offsets.begin() - 1;
      const uint64_t image_end = feature_offsets[image_idx + 1];
      size_t j = i + 1;
      while (j < end && root_and_feature[j].second < image_end) ++j;
      // Features [i, j) lie in the same image: all must be close together.
      const colmap::Image& image = reconstruction.Image(image_ids[image_idx]);
      for (size_t a = i; a < j && is_consistent; ++a) {
        for (size_t b = a + 1; b < j; ++b) {
          const Eigen::Vector2d& xy_a =
              image
                  .Point2D(root_and_feature[a].second -
                           feature_offsets[image_idx])
                  .XY();
          const Eigen::Vector2d& xy_b =
              image
                  .Point2D(root_and_feature[b].second -
                           feature_offsets[image_idx])
                  .XY();
          if ((xy_a - xy_b).squaredNorm() > max_squared_distance_px) {
            is_consistent = false;
            break;
          }
        }
      }
      candidate_observations.push_back(
          {image_ids[image_idx], static_cast<colmap::point2D_t>(
                                     feature - feature_offsets[image_idx])});
      candidate_image_idxs.push_back(image_idx);
      i = j;
    }
    const size_t num_views = candidate_observations.size() - track_begin;
    if (!is_consistent) ++num_inconsistent;
    if (!is_consistent ||
        num_views < static_cast<size_t>(options.min_num_views_per_track) ||
        num_views > static_cast<size_t>(options.max_num_views_per_track)) {
      candidate_observations.resize(track_begin);
      candidate_image_idxs.resize(track_begin);
    } else {
      candidates.offsets.push_back(candidate_observations.size());
    }
    begin = end;
  }
  return candidates;
}

// Longest tracks first (they constrain the most cameras per unknown point),
// at most max_num_tracks; with min_num_tracks_per_view, only tracks that
// see an image with fewer than that many selected tracks, until every image
// has that many. Returns candidate indices.
std::vector<size_t> SelectTracks(const TrackEstablishmentOptions& options,
                                 const CandidateTracks& candidates,
                                 size_t num_images) {
  std::vector<size_t> order(candidates.NumTracks());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return candidates.Length(a) > candidates.Length(b);
  });
  const std::vector<uint64_t>& candidate_offsets = candidates.offsets;
  const std::vector<size_t>& candidate_image_idxs = candidates.image_idxs;
  const bool has_quota = options.min_num_tracks_per_view >= 0;
  const size_t quota = has_quota ? options.min_num_tracks_per_view : 0;
  std::vector<size_t> num_tracks_per_image(num_images, 0);
  size_t num_unsatisfied_images = 0;
  if (has_quota) {
    std::vector<uint8_t> is_in_candidate(num_images, 0);
    for (const size_t image_idx : candidate_image_idxs) {
      is_in_candidate[image_idx] = 1;
    }
    num_unsatisfied_images =
        std::count(is_in_candidate.begin(), is_in_candidate.end(), 1);
  }

  std::vector<size_t> selected;
  for (const size_t idx : order) {
    if (selected.size() >= static_cast<size_t>(options.max_num_tracks)) break;
    if (has_quota) {
      if (num_unsatisfied_images == 0) break;
      bool is_needed = false;
      for (uint64_t k = candidate_offsets[idx]; k < candidate_offsets[idx + 1];
           ++k) {
        if (num_tracks_per_image[candidate_image_idxs[k]] < quota) {
          is_needed = true;
          break;
        }
      }
      if (!is_needed) continue;
      for (uint64_t k = candidate_offsets[idx]; k < candidate_offsets[idx + 1];
           ++k) {
        if (++num_tracks_per_image[candidate_image_idxs[k]] == quota) {
          --num_unsatisfied_images;
        }
      }
    }
    selected.push_back(idx);
  }

  return selected;
}

}  // namespace

TrackStore EstablishTracks(const TrackEstablishmentOptions& options,
                           const ViewGraph& view_graph,
                           const colmap::Reconstruction& reconstruction,
                           size_t* num_inconsistent_tracks) {
  if (num_inconsistent_tracks != nullptr) *num_inconsistent_tracks = 0;
  TrackStore tracks;
  if (const Status check = options.Check(); !check.ok()) {
    LOG(ERROR) << "Invalid track options: " << check.message();
    return tracks;
  }
  const FeatureIndex index(reconstruction);
  if (index.NumFeatures() >= std::numeric_limits<uint32_t>::max()) {
    LOG(ERROR) << "Too many keypoints for track establishment: "
               << index.NumFeatures();
    return tracks;
  }
  CandidateTracks candidates = MakeCandidates(
      options, reconstruction, index, JoinMatchedFeatures(view_graph, index));
  if (num_inconsistent_tracks != nullptr) {
    *num_inconsistent_tracks = candidates.num_inconsistent;
  }
  const std::vector<size_t> selected =
      SelectTracks(options, candidates, index.image_ids.size());
  size_t num_selected_observations = 0;
  for (const size_t idx : selected) {
    num_selected_observations += candidates.Length(idx);
  }
  tracks.Reserve(selected.size(), num_selected_observations);
  for (const size_t idx : selected) {
    tracks.AddTrack(
        candidates.observations.data() + candidates.offsets[idx],
        candidates.observations.data() + candidates.offsets[idx + 1]);
  }
  return tracks;
}

}  // namespace glomap
