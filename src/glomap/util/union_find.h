// Union-find (disjoint sets) over dense indices, shared by the stages that
// group things: features into tracks, images into components and clusters,
// and Kruskal's spanning tree in rotation averaging.
#pragma once

#include <cstddef>
#include <numeric>
#include <vector>

namespace glomap {

// Disjoint sets of the indices 0..size-1. Union makes the smaller root the
// root of the merged set, so every set's root is its smallest index whatever
// the order of the unions: callers group and sort by root and get the same
// result on every run. `Index` is any unsigned or signed integer type; track
// establishment uses uint32_t to halve the memory of one entry per keypoint.
template <typename Index>
class UnionFind {
 public:
  explicit UnionFind(size_t size) : parents_(size) {
    std::iota(parents_.begin(), parents_.end(), Index(0));
  }

  // The root of i's set, with path halving (every other node on the way
  // points to its grandparent afterwards).
  Index Find(Index i) {
    while (parents_[i] != i) {
      parents_[i] = parents_[parents_[i]];
      i = parents_[i];
    }
    return i;
  }

  // Merges the sets of i and j; returns false if they already were one set.
  bool Union(Index i, Index j) {
    i = Find(i);
    j = Find(j);
    if (i == j) return false;
    if (i < j) {
      parents_[j] = i;
    } else {
      parents_[i] = j;
    }
    return true;
  }

 private:
  std::vector<Index> parents_;
};

}  // namespace glomap
