#!/usr/bin/env python3
"""Tests of glomap_bench.report on made-up runs: the header, the main
table's spreads and failed runs, and the README's benchmark section."""

import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, report, tables  # noqa: E402


class HeaderTest(unittest.TestCase):
    def test_runs_line(self):
        header = report.header_lines(fixtures.benchmark_meta())
        self.assertEqual(len(header), 4)
        self.assertIn("3 for datasets", header[3])
        self.assertIn("1 for synthetic scenes", header[3])
        self.assertIn("once per seed (0,1,2)", header[3])

    def test_camera_setup_line(self):
        meta = dict(fixtures.benchmark_meta(), camera_setup="shared X")
        self.assertEqual(report.header_lines(meta)[3], "Cameras: shared X.")


class TableTest(unittest.TestCase):
    def setUp(self):
        self.meta = fixtures.benchmark_meta()

    def test_seed_spread_in_the_table(self):
        table = report.markdown_tables(
            fixtures.seed_runs() + [fixtures.stock_run()], self.meta)
        self.assertIn("4.0 s (3.0–5.0)", table)
        self.assertIn("81.0 (80.0–82.0)", table)
        self.assertIn("| 0–2 |", table)

    def test_a_failed_repeat(self):
        repeated = fixtures.repeated_runs()
        failed = dict(repeated[1], status="failed: exit 1", evaluation=None)
        table = report.markdown_tables(
            repeated[:1] + [failed] + repeated[2:], self.meta)
        self.assertIn("2.0 s (1.0–4.0)", table)
        self.assertIn("seed 1 run 1: failed: exit 1", table)

    def test_table_header(self):
        header = report.header_lines(self.meta)
        lines = report.markdown_tables(fixtures.repeated_runs(),
                                       self.meta).split("\n")
        self.assertEqual(lines[:4], header)
        self.assertEqual(lines[4], "")
        self.assertIn("| AUC@0.5° (median) | AUC@1° (median) "
                      "| AUC@3° (median) | AUC@5° (median) "
                      "| AUC@10° (median) |", lines[5])
        self.assertIn("wall time: median (min–max)", lines[5])
        self.assertEqual(lines[6].count("---"), lines[5].count("|") - 1)
        self.assertIn("AUC@0.5°: not reported", "\n".join(lines),
                      "a missing threshold is named")

    def test_per_stage_table(self):
        table = report.markdown_tables(fixtures.seed_runs(), self.meta)
        self.assertIn("| dataset | relative_poses | other | total |", table)
        self.assertIn("| d | 2.00 | 2.00 | 4.00 |", table)


class ReadmeTest(unittest.TestCase):
    def test_the_readme_block_records_the_command(self):
        meta = fixtures.benchmark_meta()
        with tempfile.TemporaryDirectory() as tmp:
            readme = os.path.join(tmp, "README.md")
            with open(readme, "w") as f:
                f.write("# t\n\n%s\nOLD BLOCK\n%s\n\nafter\n" % (
                    report.README_BEGIN, report.README_END))
            report.update_readme(readme, report.markdown_tables(
                fixtures.repeated_runs(), meta), None)
            text = tables.read_text(readme)
        block = text.split(report.README_BEGIN)[1].split(
            report.README_END)[0]
        self.assertNotIn("OLD BLOCK", text)
        self.assertTrue(text.endswith("\nafter\n"))
        self.assertEqual(block.count(meta["command"]), 1)
        self.assertNotIn("Regenerate with", block)
        self.assertIn("| AUC@0.5° (median)", block)

    def test_appended_with_the_plot(self):
        with tempfile.TemporaryDirectory() as tmp:
            readme = os.path.join(tmp, "README.md")
            with open(readme, "w") as f:
                f.write("# t\n")
            plot = os.path.join(tmp, "auc_per_dataset.png")
            with open(plot, "wb") as f:
                f.write(b"png")
            report.update_readme(readme, "provenance\n\ntable\n", plot)
            self.assertEqual(tables.read_text(readme), (
                "# t\n\n## Benchmark\n\n%s\n\nprovenance\n\n"
                "![Pairwise AUC per dataset](docs/benchmark/"
                "auc_per_dataset.png)\n\ntable\n\n%s\n" % (
                    report.README_BEGIN, report.README_END)))
            self.assertTrue(os.path.isfile(os.path.join(
                tmp, "docs", "benchmark", "auc_per_dataset.png")))


if __name__ == "__main__":
    unittest.main()
