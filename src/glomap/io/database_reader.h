// The pipeline's input edge: reads a COLMAP 3.8 database without ever
// changing it. colmap::Database opens read-write, creates missing tables and
// sets pragmas (journal mode, user_version), so a user's database would be
// modified just by running the mapper; this reader talks to SQLite directly
// through a read-only (and, when safe, immutable) connection instead.
#pragma once

#include <string>
#include <vector>

#include "base/reconstruction.h"
#include "glomap/scene/view_graph.h"
#include "glomap/util/status.h"

namespace glomap {

struct DatabaseReaderOptions {
  // Pairs with fewer verified (inlier) matches are ignored
  // (COLMAP's Mapper.min_num_matches).
  int min_num_matches = 15;

  // Whether to drop pairs that the matcher flagged as WATERMARK
  // (COLMAP's Mapper.ignore_watermarks).
  bool ignore_watermarks = false;

  // When non-empty, only images with these names are read (and only pairs
  // between two of them); names that are not in the database are ignored.
  std::vector<std::string> image_names;

  // The first violation, naming the field as `prefix` + its name.
  Status Check(const std::string& prefix = "") const;
};

// Reads the database at `database_path` into an empty `reconstruction` and
// `view_graph`:
//  - the cameras used by the read images (params as stored, prior flag);
//  - the images with their keypoints as Points2D (x, y in pixels), not
//    registered, identity pose, pose priors as stored;
//  - one ImagePair per verified pair: a two_view_geometries row with at
//    least `min_num_matches` inliers whose config is not UNDEFINED,
//    DEGENERATE or MULTIPLE (nor WATERMARK when `ignore_watermarks`), with
//    config, F, E, H (column-major), the inlier matches and the number of raw
//    matches.
//
// Damaged content never reaches the pipeline. What makes the file unreadable
// (a wrong schema, blobs of the wrong size, an image without its camera, an
// unknown camera model) is a one-line error. What only spoils a part is left
// out with one warning per kind that says what and how much, as COLMAP's own
// tools would treat it:
//  - a camera with non-finite parameters, a focal length that is not
//    positive or a principal point farther outside the image than the
//    image's size: its images are left out (COLMAP's incremental mapper
//    skips images whose camera has bogus parameters); when that leaves no
//    image, the error names the camera;
//  - repeated rows of an id (tables without their primary key): the first
//    row is used, which is the one COLMAP's Database reads, and so the one
//    its matchers used;
//  - keypoints with NaN or infinite coordinates: they keep their index but
//    no match that uses them is read (one warning per image);
//  - matches with keypoint indices out of range are dropped;
//  - pairs that name images not in the database, or whose config is not a
//    COLMAP TwoViewGeometry type: ignored;
//  - F, E or H stored as NULL, empty or non-finite: set to zero (not
//    estimated), the pair's inlier matches are kept;
//  - pairs left with fewer than `min_num_matches` matches: ignored.
// A database with fewer than two usable images, or without a usable pair,
// is an error.
//
// Nothing is written beside the database (it may sit on a read-only mount):
// it is read immutably, without locks, and read again when its size or
// times changed meanwhile (another program wrote to it; after three tries
// that is an error). Only when a write-ahead log or journal holds changes
// not yet in the file does the read go through SQLite's locks, in one
// transaction, waiting up to 30 s for a writer's lock.
Status ReadDatabase(const std::string& database_path,
                    const DatabaseReaderOptions& options,
                    colmap::Reconstruction* reconstruction,
                    ViewGraph* view_graph);

}  // namespace glomap
