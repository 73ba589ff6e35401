#include "glomap/util/union_find.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace glomap {
namespace {

TEST(UnionFind, StartsWithSingletons) {
  UnionFind<uint32_t> union_find(5);
  for (uint32_t i = 0; i < 5; ++i) EXPECT_EQ(union_find.Find(i), i);
}

TEST(UnionFind, UnionSaysWhetherItMerged) {
  UnionFind<int> union_find(4);
  EXPECT_TRUE(union_find.Union(3, 1));
  EXPECT_FALSE(union_find.Union(1, 3));
  EXPECT_FALSE(union_find.Union(2, 2));
  EXPECT_TRUE(union_find.Union(2, 0));
  EXPECT_TRUE(union_find.Union(2, 3));
  EXPECT_FALSE(union_find.Union(0, 1));
}

TEST(UnionFind, RootIsTheSmallestIndexWhateverTheOrder) {
  UnionFind<size_t> union_find(6);
  union_find.Union(5, 4);
  union_find.Union(4, 3);
  EXPECT_EQ(union_find.Find(5), 3);
  union_find.Union(2, 5);
  for (const size_t i : {2, 3, 4, 5}) EXPECT_EQ(union_find.Find(i), 2);
  EXPECT_EQ(union_find.Find(0), 0);
  EXPECT_EQ(union_find.Find(1), 1);
}

// Against connected components found by flooding, over random graphs and
// random edge orders: the same sets, each rooted at its smallest index.
TEST(UnionFind, MatchesFloodFillOnRandomGraphs) {
  std::mt19937 rng(42);
  for (int trial = 0; trial < 50; ++trial) {
    const size_t n = 1 + rng() % 200;
    const size_t num_edges = rng() % (2 * n);
    std::vector<std::pair<size_t, size_t>> edges;
    std::vector<std::vector<size_t>> neighbors(n);
    for (size_t e = 0; e < num_edges; ++e) {
      const size_t a = rng() % n;
      const size_t b = rng() % n;
      edges.emplace_back(a, b);
      neighbors[a].push_back(b);
      neighbors[b].push_back(a);
    }
    std::vector<size_t> smallest_in_component(n, n);
    for (size_t start = 0; start < n; ++start) {
      if (smallest_in_component[start] != n) continue;
      std::vector<size_t> stack = {start};
      smallest_in_component[start] = start;
      while (!stack.empty()) {
        const size_t node = stack.back();
        stack.pop_back();
        for (const size_t next : neighbors[node]) {
          if (smallest_in_component[next] != n) continue;
          smallest_in_component[next] = start;
          stack.push_back(next);
        }
      }
    }
    for (int order = 0; order < 3; ++order) {
      std::shuffle(edges.begin(), edges.end(), rng);
      UnionFind<uint32_t> union_find(n);
      size_t num_merges = 0;
      for (const auto& [a, b] : edges) {
        num_merges += union_find.Union(static_cast<uint32_t>(a),
                                       static_cast<uint32_t>(b));
      }
      size_t num_components = 0;
      for (size_t i = 0; i < n; ++i) {
        EXPECT_EQ(union_find.Find(static_cast<uint32_t>(i)),
                  smallest_in_component[i]);
        num_components += smallest_in_component[i] == i;
      }
      // A spanning forest has one edge fewer than nodes per component.
      EXPECT_EQ(num_merges, n - num_components);
    }
  }
}

}  // namespace
}  // namespace glomap
