#!/usr/bin/env python3
"""Tests of glomap_bench.stats: medians over runs and the log-log slope."""

import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, stats  # noqa: E402


class MedianTest(unittest.TestCase):
    def test_median(self):
        self.assertEqual(stats.median([3.0, None, 1.0, 2.0]), 2.0)
        self.assertIsNone(stats.median([]))
        self.assertEqual(repr(stats.median([30, 30])), "30",
                         "counts stay counts")
        self.assertEqual(stats.median([1, 2]), 1.5)

    def test_the_lower_middle_run_of_an_even_count(self):
        self.assertEqual(stats.median_time_run(
            [{"wall_time_s": t, "k": t} for t in (5.0, 1.0, 2.0, 9.0)])["k"],
            2.0)


class SlopeTest(unittest.TestCase):
    def test_slope_of_n_to_the_1_5(self):
        self.assertAlmostEqual(stats.fit_slope(
            [(n, 3e-4 * n ** 1.5) for n in fixtures.SIZES]), 1.5, delta=1e-9)

    def test_constant_has_slope_0(self):
        self.assertAlmostEqual(stats.fit_slope(
            [(n, 7.0) for n in fixtures.SIZES]), 0.0, delta=1e-12)

    def test_none_and_0_are_skipped(self):
        self.assertAlmostEqual(stats.fit_slope(
            [(1000, 1.0), (2000, None), (4000, 4.0), (8000, 0.0)]), 1.0,
            delta=1e-9)

    def test_one_size_has_no_slope(self):
        self.assertIsNone(stats.fit_slope([(1000, 1.0), (1000, 2.0)]))
        self.assertIsNone(stats.fit_slope([]))

    def test_least_squares_not_the_end_points(self):
        # (1,1), (2,4), (4,4) in log2.
        self.assertAlmostEqual(stats.fit_slope(
            [(2, 2.0), (4, 16.0), (16, 16.0)]), 6.0 / 7.0, delta=1e-9)


if __name__ == "__main__":
    unittest.main()
