#!/usr/bin/env python3
"""Tests of glomap_bench.mappers: the order of the runs, their folders,
titles and summary lines."""

import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, mappers  # noqa: E402


class ScheduleTest(unittest.TestCase):
    def test_the_mappers_alternate(self):
        self.assertEqual(
            mappers.run_schedule(["global", "incremental", "reference"],
                                 [0], 2),
            [("global", 0, 0), ("incremental", None, 0),
             ("reference", None, 0), ("global", 0, 1),
             ("incremental", None, 1), ("reference", None, 1)])

    def test_schedule_with_seeds(self):
        self.assertEqual(mappers.run_schedule(["reference", "global"],
                                              [3, 4], 1),
                         [("global", 3, 0), ("global", 4, 0),
                          ("reference", None, 0)])

    def test_a_fresh_folder_per_run(self):
        self.assertEqual(mappers.run_dir_name("global", 2, 1),
                         "global_seed2_run2")
        self.assertEqual(mappers.run_dir_name("reference", None, 0),
                         "reference_run1")


class RunTextTest(unittest.TestCase):
    def test_titles(self):
        self.assertEqual(mappers.run_title("global", 0, 1, 3),
                         "global_mapper (seed 0, run 2/3)")
        self.assertEqual(mappers.run_title("reference", None, 0, 1),
                         "reference global_mapper")

    def test_summary_line(self):
        record = fixtures.dataset_run("global", 0, 9, 90.0, 2.0, beyond=1)
        self.assertEqual(
            mappers.run_summary(record, 2.04, 65.4, None),
            "ok, 2.0 s, 65 MB, 9/10 registered, AUC@3 90.0, 1 camera(s) "
            "beyond 5% of the scene, re-placed 1, left out 0")


if __name__ == "__main__":
    unittest.main()
