#!/usr/bin/env python3
"""Tests of glomap_bench.report_plots on made-up runs: the data of the
runtime and AUC plots (gnuplot itself is not needed)."""

import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, report_plots, summary  # noqa: E402


class PlotDataTest(unittest.TestCase):
    def setUp(self):
        self.rows = summary.summary_records(
            fixtures.seed_runs() + [fixtures.stock_run()])

    def test_runtime_rows(self):
        columns = ["relative_poses", "other", "COLMAP 3.8 mapper (total)"]
        rows = report_plots.runtime_rows(self.rows, ["relative_poses"],
                                         columns)
        self.assertEqual(rows, [["d (global, median)", 2.0, 2.0, 0.0],
                                ["d (incr.)", 0.0, 0.0, 100.0]])

    def test_auc_data(self):
        self.assertEqual(report_plots.auc_data(
            self.rows, ["d"], ["3", "0.5"], ["global", "incremental"]),
            ['"d" 81.000 70.200 0 0'])


if __name__ == "__main__":
    unittest.main()
