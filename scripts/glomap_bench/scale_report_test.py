#!/usr/bin/env python3
"""Tests of glomap_bench.scale_report on made-up runs: the tables of each
layout, the slope table and verdict, and the README's scale section."""

import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, report, scale_report, tables  # noqa: E402


class ReportTest(unittest.TestCase):
    def setUp(self):
        self.records = fixtures.scale_records()
        self.meta = fixtures.scale_meta()
        self.report = scale_report.markdown_report(self.records, self.meta)

    def test_provenance_first(self):
        self.assertTrue(self.report.startswith(
            "Command: `python3 scripts/benchmark_scale.py --sizes 1000` "
            "(in `/work/main`).\n"), self.report[:200])

    def test_one_section_per_layout_in_order(self):
        self.assertIn("### survey (`grid` layout)", self.report)
        self.assertIn("### street (`forward` layout)", self.report)
        self.assertLess(self.report.index("### survey"),
                        self.report.index("### street"))

    def test_rows_as_wide_as_their_header(self):
        widths = {}
        header = None
        for line in self.report.split("\n"):
            if not line.startswith("|"):
                header = None
                continue
            if header is None:
                header = line.count("|")
            widths.setdefault(header, []).append(line.count("|"))
        for width, counts in widths.items():
            self.assertEqual(set(counts), {width})

    def test_a_timed_out_run(self):
        self.assertIn("| 10000 | 10.00 | – | – | – | 60.00 | 250 MB "
                      "| **timeout after 60 s in rotation_averaging** | – "
                      "| – | – | – |", self.report)
        self.assertIn("| 10000 | 200 | 250 | – | – | 250 "
                      "| 100.0 s, 1000 MB | – |", self.report)

    def test_the_slope_table_flags_1_5(self):
        self.assertIn("| rotation_averaging | 1.50 | 0.50 |", self.report)
        self.assertIn("**time**", self.report)

    def test_a_negligible_stage_is_marked(self):
        self.assertIn("| camera_clustering | 1.40 | – |", self.report)
        self.assertIn("time negligible", self.report)

    def test_the_street_fit_leaves_out_the_timed_out_size(self):
        self.assertIn("Log-log slopes (least squares over n = 1000, 2000, "
                      "5000; ", self.report)

    def test_a_time_row(self):
        self.assertIn("| 1000 | 1.00 | 0.32 | 0.00 | 0.50 | 1.82 | 95 MB "
                      "| 1000/1000 | 50.0 | 80.0 | 90.0 | 0.012° |",
                      self.report)

    def test_a_memory_row(self):
        self.assertIn("| 1000 | 63 | 95 | – | 32 | 95 | 10.0 s, 100 MB "
                      "| 1.0 s |", self.report)

    def test_resumed_runs_are_named(self):
        self.assertNotIn("Kept from an earlier", self.report)
        resumed = scale_report.markdown_report(
            [dict(self.records[0], resumed=True)] + self.records[1:],
            self.meta)
        self.assertIn("(--resume): survey 1000 (seed 0).", resumed)

    def test_the_verdict_line(self):
        self.assertIn("Slopes above 1.2: survey rotation_averaging (time); "
                      "survey camera_clustering (time); street "
                      "rotation_averaging (time); street camera_clustering "
                      "(time).", self.report)

    def test_a_failed_seed_is_named(self):
        failed_seed = self.records + [fixtures.scale_record(
            "grid", 1000, seed=1, status="killed by SIGKILL")]
        self.assertIn("1000/1000 (seed 1: killed by SIGKILL in "
                      "rotation_averaging)", scale_report.markdown_report(
                          failed_seed, dict(self.meta, seeds=[0, 1])))


class ReadmeTest(unittest.TestCase):
    """The README section: inserted before the benchmark section, then
    replaced."""

    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.report = scale_report.markdown_report(fixtures.scale_records(),
                                                   fixtures.scale_meta())

    def tearDown(self):
        self.dir.cleanup()

    def test_inserted_then_replaced(self):
        tmp = self.dir.name
        readme = os.path.join(tmp, "README.md")
        with open(readme, "w") as f:
            f.write("# t\n\n## Evaluation\n\ntext\n\n## Benchmark\n\n%s\n"
                    "old\n%s\n" % (report.README_BEGIN, report.README_END))
        plot = os.path.join(tmp, "time_vs_images.png")
        with open(plot, "wb") as f:
            f.write(b"png")
        scale_report.update_readme(readme, self.report, [plot])
        text = tables.read_text(readme)
        self.assertGreater(text.index(scale_report.README_HEADING),
                           text.index("## Evaluation"))
        self.assertLess(text.index(scale_report.README_END),
                        text.index("## Benchmark\n\n" + report.README_BEGIN))
        self.assertIn("![Wall time per stage against images](docs/benchmark/"
                      "scale_time_vs_images.png)", text)
        self.assertTrue(os.path.isfile(os.path.join(
            tmp, "docs", "benchmark", "scale_time_vs_images.png")))
        scale_report.update_readme(
            readme, self.report.replace("today", "tomorrow"), [])
        text2 = tables.read_text(readme)
        self.assertEqual(text2.count(scale_report.README_BEGIN), 1)
        self.assertIn("tomorrow", text2)
        self.assertNotIn("today", text2)
        self.assertIn("old", text2)
        self.assertEqual(text2.count("## Benchmark"), 1)

    def test_a_readme_without_a_benchmark_section(self):
        plain = os.path.join(self.dir.name, "PLAIN.md")
        with open(plain, "w") as f:
            f.write("# p\n")
        scale_report.update_readme(plain, self.report, [])
        self.assertTrue(tables.read_text(plain).startswith(
            "# p\n\n## Scale benchmark\n\n" + scale_report.README_BEGIN))


class ComparisonTest(unittest.TestCase):
    """--reference_colmap: the reference's runs get a table of their own
    beside ours and stay out of our tables."""

    def setUp(self):
        self.records = fixtures.scale_records()
        reference = fixtures.scale_record("grid", 1000)
        reference.update(mapper="reference", wall_time_s=3.64,
                         peak_rss_mb=190.0, stages=[])
        reference["evaluation"] = dict(reference["evaluation"],
                                       **{"auc@3": 88.1})
        self.records.append(reference)
        self.report = scale_report.markdown_report(self.records,
                                                   fixtures.scale_meta())

    def test_comparison_row(self):
        self.assertIn("### Ours against the reference `global_mapper`",
                      self.report)
        row = next(line for line in self.report.split("\n")
                   if line.startswith("| survey | 1000 | 0 |"))
        cells = [c.strip() for c in row.strip("|").split("|")]
        # ours: 1.82 s, 95 MB, AUC@3 80.0; the reference 3.64 s, 190 MB.
        self.assertEqual(cells[3:9], ["1.8 s", "3.6 s", "0.50", "95 MB",
                                      "190 MB", "0.50"])
        self.assertEqual(cells[9:13], ["80.0", "88.1", "1000/1000",
                                       "1000/1000"])

    def test_reference_stays_out_of_our_tables(self):
        without = scale_report.markdown_report(
            [r for r in self.records if r.get("mapper") != "reference"],
            fixtures.scale_meta())
        self.assertNotIn("Ours against the reference", without)
        self.assertEqual(self.report.replace(
            "\n".join(scale_report.comparison_table(self.records)) + "\n",
            ""),
            without)


if __name__ == "__main__":
    unittest.main()
