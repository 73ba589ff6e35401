#!/usr/bin/env python3
"""Tests of glomap_bench.bars on made-up runs: the bars against the README's
reference figures and, on stock-relative datasets, against the stock
mapper."""

import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import bars, fixtures  # noqa: E402

run = fixtures.dataset_run


def check(record, reference, stock=None, stock_relative=False,
          max_position_error=None):
    return bars.check_bars("colmap", record, reference, stock,
                           stock_relative, max_position_error)


class ReadmeBarsTest(unittest.TestCase):
    def setUp(self):
        self.readme = fixtures.readme_figures()

    def test_plain_pass(self):
        self.assertEqual(check(run("global", 0, 10, 90.5, 2),
                               self.readme)["result"], "pass")

    def test_auc_compared_at_one_decimal(self):
        row = check(run("global", 0, 10, 90.46, 2), self.readme)
        self.assertEqual(row["result"], "pass")
        self.assertEqual(row["cells"]["auc@3"], "90.5 ≥ 90.5 (README)")

    def test_auc_below_the_better_reference(self):
        row = check(run("global", 0, 10, 90.44, 2), self.readme)
        self.assertEqual(row["failed"], ["AUC@3"])

    def test_registration_and_cameras_beyond(self):
        row = check(run("global", 0, 9, 95, 2, beyond=1), self.readme)
        self.assertEqual(row["failed"], ["registered", "cameras beyond"])

    def test_an_evaluator_without_cameras_beyond(self):
        row = check(run("global", 0, 10, 95, 2, beyond=None), self.readme)
        self.assertEqual(row["unchecked"], ["cameras beyond"])
        self.assertFalse(row["failed"])

    def test_position_error_bar(self):
        row = check(run("global", 0, 10, 95, 2, pos=0.03), self.readme,
                    max_position_error=0.02)
        self.assertEqual(row["failed"], ["position error"])

    def test_no_readme_figures(self):
        row = check(run("global", 0, 10, 95, 2), None)
        self.assertEqual(row["result"], "pass")
        self.assertEqual(row["verdicts"]["auc@3"], bars.NOT_APPLICABLE)


class StockRelativeTest(unittest.TestCase):
    """dino-363: the stock mapper of the same run."""

    def setUp(self):
        self.stock = fixtures.stock_run()
        self.dino = {"incremental": fixtures.readme_figures()["incremental"]}
        self.good = run("global", 1, 9, 69.2, 50.0, beyond=0,
                        names=["1", "2", "3", "4", "5", "6", "7", "8", "9"])

    def test_pass(self):
        row = check(self.good, self.dino, self.stock, True)
        self.assertEqual(row["result"], "pass", str(row))
        self.assertEqual(row["cells"]["registered"], "9/10 ⊇ stock's 8")

    def test_failures(self):
        bad = run("global", 2, 9, 69.1, 50.1, beyond=0,
                  names=["1", "2", "3", "4", "5", "6", "7", "9", "10"])
        row = check(bad, self.dino, self.stock, True)
        self.assertEqual(row["failed"], ["registered", "AUC@3", "time"])
        self.assertIn("misses 1", row["cells"]["registered"],
                      "the missing image is named")

    def test_with_the_readme_stock_figures(self):
        row = check(run("global", 0, 10, 89.0, 9.0), self.dino, None, True)
        self.assertEqual(row["result"], "pass")
        self.assertIn("README", row["cells"]["time"])

    def test_a_failed_stock_mapper(self):
        failed_stock = dict(self.stock, status="failed: no model",
                            evaluation=None)
        row = check(self.good, self.dino, failed_stock, True)
        self.assertIs(row["verdicts"]["registered"], True)
        self.assertIs(row["verdicts"]["auc@3"], True)


class AllBarsTest(unittest.TestCase):
    def test_no_runs(self):
        self.assertIs(bars.all_bars_met([])[0], False)

    def test_per_dataset_and_seed(self):
        with tempfile.TemporaryDirectory() as tmp:
            dataset = os.path.join(tmp, "d")
            os.makedirs(dataset)
            with open(os.path.join(dataset, "README.md"), "w") as f:
                f.write("| mapper | wall time | registered | AUC@3° |\n"
                        "|---|---|---|---|\n"
                        "| COLMAP 3.8 incremental `mapper` | 20s | 10/10 "
                        "| 80.0 |\n")
            records = fixtures.seed_runs() + [fixtures.stock_run()]
            rows = bars.compute_bars("colmap", records, [dataset])
        self.assertEqual([r["seed"] for r in rows], [0, 1, 2])
        self.assertTrue(all(r["stock_relative"] for r in rows),
                        "a README without upstream figures")
        met, line = bars.all_bars_met(rows)
        self.assertIs(met, False)
        self.assertEqual(line, "all bars met: no (1 of 3 runs fail)")
        table = bars.bars_table(rows, "cameras beyond 5%")
        self.assertIn("| d (stock-relative) | 2 |", table)
        self.assertTrue(table.endswith(line + "\n"))


if __name__ == "__main__":
    unittest.main()
