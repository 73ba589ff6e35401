#!/usr/bin/env python3
"""Tests of glomap_bench.scale_summary on made-up runs: the slopes per
stage, medians over seeds, failed runs."""

import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, scale_summary  # noqa: E402


class SlopesTest(unittest.TestCase):
    def test_slopes(self):
        entries = {e["name"]: e for e in scale_summary.slopes(
            scale_summary.layout_rows(fixtures.scale_records(), "grid"))}
        rotation = entries["rotation_averaging"]
        self.assertAlmostEqual(rotation["time_slope"], 1.5, delta=1e-9)
        self.assertEqual(rotation["flags"], ["time"])
        self.assertAlmostEqual(entries["database"]["time_slope"], 1.0,
                               delta=1e-9)
        self.assertEqual(entries["database"]["flags"], [])
        self.assertAlmostEqual(entries["total"]["memory_slope"], 0.5,
                               delta=1e-9)
        self.assertIsNone(entries["camera_clustering"]["memory_slope"])

    def test_every_layout(self):
        slope_map = scale_summary.all_slopes(fixtures.scale_records(),
                                             ["forward"])
        self.assertEqual(list(slope_map), ["forward", "grid"])


class SummarizeTest(unittest.TestCase):
    def test_median_over_seeds(self):
        records = fixtures.scale_records()
        two_seeds = records + [dict(fixtures.scale_record("grid", 1000,
                                                          seed=1),
                                    wall_time_s=10.0)]
        row = scale_summary.summarize(two_seeds, "grid", 1000)
        self.assertEqual(row["runs"], 2)
        self.assertEqual(row["total_s"],
                         (records[0]["wall_time_s"] + 10.0) / 2)

    def test_a_run_that_stopped(self):
        row = scale_summary.summarize(fixtures.scale_records(), "forward",
                                      10000)
        self.assertEqual(row["status_text"],
                         "timeout after 60 s in rotation_averaging")
        self.assertEqual(row["stage_names"],
                         ["database", "rotation_averaging"])
        self.assertIsNone(scale_summary.summarize([], "grid", 1))


if __name__ == "__main__":
    unittest.main()
