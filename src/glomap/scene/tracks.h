// Feature tracks in flat arrays: observations of all tracks stored back to
// back, with one offset per track (no per-track containers, so 10 M tracks
// cost two vectors, not 10 M allocations).
#pragma once

#include <cstdint>
#include <vector>

#include "util/types.h"

namespace glomap {

struct TrackObservation {
  colmap::image_t image_id;
  colmap::point2D_t point2D_idx;
};

class TrackStore {
 public:
  size_t NumTracks() const {
    return offsets_.empty() ? 0 : offsets_.size() - 1;
  }
  size_t NumObservations() const { return observations_.size(); }

  // Appends one track; returns its index.
  size_t AddTrack(const TrackObservation* begin, const TrackObservation* end) {
    if (offsets_.empty()) offsets_.push_back(0);
    observations_.insert(observations_.end(), begin, end);
    offsets_.push_back(observations_.size());
    return offsets_.size() - 2;
  }
  size_t AddTrack(const std::vector<TrackObservation>& track) {
    return AddTrack(track.data(), track.data() + track.size());
  }

  // Observations of track `idx` are [TrackBegin(idx), TrackEnd(idx)).
  const TrackObservation* TrackBegin(size_t idx) const {
    return observations_.data() + offsets_[idx];
  }
  const TrackObservation* TrackEnd(size_t idx) const {
    return observations_.data() + offsets_[idx + 1];
  }
  size_t TrackLength(size_t idx) const {
    return offsets_[idx + 1] - offsets_[idx];
  }

  void Reserve(size_t num_tracks, size_t num_observations) {
    offsets_.reserve(num_tracks + 1);
    observations_.reserve(num_observations);
  }
  // Removes every track and frees the memory (clear() would keep it).
  void Clear() {
    std::vector<uint64_t>().swap(offsets_);
    std::vector<TrackObservation>().swap(observations_);
  }

 private:
  std::vector<uint64_t> offsets_;
  std::vector<TrackObservation> observations_;
};

}  // namespace glomap
