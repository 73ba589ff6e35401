// Track establishment (paper Sec. 3; glomap.md §2.5 and §4): concatenates the
// inlier matches of the view graph into feature tracks, one 3D point each.
#pragma once

#include <cstddef>
#include <string>

#include "base/reconstruction.h"
#include "glomap/scene/tracks.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/status.h"

namespace glomap {

struct TrackEstablishmentOptions {
  // A track with two observations in one image farther apart than this (in
  // pixels) merged two different scene points and is dropped.
  double max_intra_image_distance_px = 10.0;
  // Tracks seen in fewer distinct registered images are dropped.
  int min_num_views_per_track = 3;
  // Tracks seen in more distinct images are dropped (likely chained mismatches
  // through repetitive structure; same as the reference).
  int max_num_views_per_track = 100;
  // Hard cap on the number of tracks returned, longest tracks first.
  int max_num_tracks = 10000000;
  // Per-image quota: longest tracks are taken until every image lies in at
  // least this many taken tracks; a track is taken only while one of its
  // images is below the quota. -1 = no quota (take all tracks); otherwise
  // > 0. Global positioning and the bundle-adjustment rounds after it work
  // on these tracks only, and their cost grows with the observations;
  // retriangulation then rebuilds the structure from all verified matches.
  // Measured with 500 (the earlier default) and 200: on the six shared
  // datasets the same accuracy (AUC@3 within 0.4 points except
  // KITTI_sequence_1, 71.2 -> 68.9 and castle-P19, 79.6 -> 80.9; mean
  // position error within 6 %, castle-P19 0.103 -> 0.096), with positioning
  // and the BA rounds together 1.7-3x faster (KITTI_sequence_1: 2592 -> 842
  // tracks, about 11 s -> 6.3 s; fountain-P11: 1.1 s -> 0.36 s).
  // 150 was faster still but left one image of the 200-image synthetic ring
  // with too few points for retriangulation to recover from (its largest
  // pairwise rotation error 0.07 -> 0.15 deg; 0.07 again at 200).
  int min_num_tracks_per_view = 200;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// Union-find over the features (image_id, point2D_idx) joined by the inlier
// matches (ImagePair::inlier_idxs into ImagePair::matches) of valid pairs
// between registered images of `reconstruction`, then selection as described
// by the options. Each track keeps at most one observation per image (COLMAP
// forbids two): a track whose observations in one image are farther apart
// than max_intra_image_distance_px is dropped and counted in
// `num_inconsistent_tracks`, otherwise the feature with the smallest
// point2D_idx is kept. Observations within a track are sorted by image id;
// tracks are ordered longest first, ties by their smallest feature. Matches
// that refer to non-existent keypoints are ignored. Invalid options give no
// tracks (the error is logged; the global mapper checks its options first).
TrackStore EstablishTracks(const TrackEstablishmentOptions& options,
                           const ViewGraph& view_graph,
                           const colmap::Reconstruction& reconstruction,
                           size_t* num_inconsistent_tracks = nullptr);

}  // namespace glomap
