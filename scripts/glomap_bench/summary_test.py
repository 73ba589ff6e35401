#!/usr/bin/env python3
"""Tests of glomap_bench.summary: medians over seeds and repeats, per-seed
summaries, the notes on how runs are combined."""

import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, summary  # noqa: E402


class SummarizeTest(unittest.TestCase):
    def test_median_over_seeds(self):
        runs = fixtures.seed_runs()
        for run, peak_mb in zip(runs, (60.0, 80.0, 70.0)):
            run["peak_rss_mb"] = peak_mb
        result = summary.summarize_runs(runs)
        self.assertEqual(result["wall_time_s"], 4.0)
        self.assertEqual(result["peak_rss_mb"], 80.0, "the largest peak")
        self.assertEqual(result["evaluation"]["auc@3"], 81.0)

    def test_median_over_seeds_and_repeats(self):
        result = summary.summarize_runs(fixtures.repeated_runs())
        self.assertEqual(result["wall_time_s"], 2.5)
        self.assertEqual(result["evaluation"]["auc@3"], 81.0)
        self.assertNotIn("seed", result)

    def test_per_seed_medians(self):
        per_seed = summary.seed_summaries(fixtures.repeated_runs(), "d")
        self.assertEqual([x["seed"] for x in per_seed], [0, 1])
        self.assertEqual([x["wall_time_s"] for x in per_seed], [2.0, 4.0])
        self.assertEqual(per_seed[1]["model_path"], "m12",
                         "the model of the run with the median time")

    def test_one_run_is_itself(self):
        run = fixtures.stock_run()
        self.assertEqual(summary.summarize_runs([run]), dict(run,
                                                             runs=[run]))

    def test_rows_per_dataset_and_mapper(self):
        rows = summary.summary_records(
            [fixtures.stock_run()] + fixtures.seed_runs())
        self.assertEqual([r["mapper"] for r in rows],
                         ["global", "incremental"])


class RunsNoteTest(unittest.TestCase):
    def test_runs_notes(self):
        self.assertEqual(summary.runs_note(fixtures.repeated_runs()),
                         " (median of 6 runs: 2 seeds × 3 repeats)")
        self.assertEqual(summary.runs_note(fixtures.seed_runs()),
                         " (median of 3 seeds)")
        self.assertEqual(summary.runs_note(fixtures.repeated_runs()[:1]), "")
        self.assertEqual(summary.runs_note(
            [dict(fixtures.stock_run(), repeat=k) for k in range(3)]),
            " (median of 3 runs)")

    def test_run_labels(self):
        self.assertEqual(summary.run_label({"seed": 0, "repeat": 1}),
                         "seed 0 run 2")
        self.assertEqual(summary.run_label({}), "run")


if __name__ == "__main__":
    unittest.main()
