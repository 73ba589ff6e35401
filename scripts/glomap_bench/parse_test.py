#!/usr/bin/env python3
"""Tests of glomap_bench.parse: the mapper's log lines (also while the log
grows), the generator's summary, a dataset README's reference figures."""

import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import parse  # noqa: E402

REFERENCE_TABLE = (
    "# x\n\n## Reference figures\ntext\n\n"
    "| mapper | wall time | registered | AUC@1° | AUC@3° | AUC@5° "
    "| AUC@10° | mean position error |\n"
    "|---|---|---|---|---|---|---|---|\n"
    "| COLMAP 3.8 incremental %s | 39.7s | %s | – | %s | – | – | – |\n"
    "%s")
UPSTREAM_ROW = (
    "| COLMAP 4.1.1 \\`global_mapper\\` (upstream) | 59.6s | 51/51 "
    "| 2.7 | 66.2 | 79.7 | 89.8 | 0.0146 |\n")
OUR_ROW = (
    "| this project's `global_mapper` at commit 3942e28 | 80.2s "
    "| 199/363 | 5.3 | 95.5 | 24.1 | 26.9 | 0.007077 |\n")


class ReferenceTextTest(unittest.TestCase):
    def test_failed_stock_and_upstream(self):
        ref = parse.parse_reference_text(REFERENCE_TABLE % (
            "`mapper`", "failed: no model", "–", UPSTREAM_ROW))
        self.assertIsNone(ref["incremental"]["auc@3"], "'–' is no figure")
        self.assertIsNone(ref["incremental"]["registered"],
                          "failed registration")
        self.assertEqual(ref["upstream"]["auc@3"], 66.2, "escaped backticks")
        self.assertEqual(ref["upstream"]["wall_time_s"], 59.6, "wall time")

    def test_own_rows_are_ignored(self):
        ref = parse.parse_reference_text(REFERENCE_TABLE % (
            "\\`mapper\\`", "363/363", "70.2", OUR_ROW))
        self.assertEqual(set(ref), {"incremental"},
                         "this project's rows are ignored")
        self.assertEqual(ref["incremental"]["registered"], [363, 363],
                         "registered")
        self.assertIsNone(parse.reference_row_key(
            "this project's global_mapper with COLMAP 4.1's options"))

    def test_no_reference_table(self):
        self.assertIsNone(parse.parse_reference_text(
            "# no table\n| a | b |\n|---|---|\n"))

    def test_number_of_a_cell(self):
        self.assertEqual(parse.parse_number("8.7s"), 8.7)
        self.assertIsNone(parse.parse_number("–"))


class LogLineTest(unittest.TestCase):
    def test_final_line_with_a_warning(self):
        match = parse.FINISH_RE.search(
            "Global mapper finished in 2.0 s: 1 model(s), 51 of 51 images "
            "registered; pose verification re-placed 0 and left out 0 "
            "image(s); 1 warning(s): Focal lengths not determined: ...")
        self.assertEqual(match.group(3), "51")

    def test_final_line(self):
        match = parse.FINISH_RE.search(
            "I1201 12:00:00.1 global_mapper.cc:355] Global mapper finished "
            "in 12.3 s: 1 model(s), 47 of 47 images registered; pose "
            "verification re-placed 2 and left out 1 image(s).")
        self.assertTrue(match)
        self.assertEqual((match.group(5), match.group(6)), ("2", "1"))

    def test_final_line_of_an_older_binary(self):
        self.assertIsNone(parse.FINISH_RE.search(
            "Global mapper finished in 1.0 s: 2 model(s), 5 of 8 images "
            "registered.").group(5))

    def test_stage_line(self):
        self.assertEqual(parse.STAGE_RE.search(
            "Stage Final pose verification: 0.250 s (a=1)").group(1),
            "Final pose verification")

    def test_stage_start_line_is_no_stage_time(self):
        self.assertIsNone(parse.STAGE_RE.search(
            "Stage Pose verification ..."))

    def test_finish_and_generator_summary_of_files(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "log.txt")
            with open(path, "w") as f:
                f.write("x\nGlobal mapper finished in 12.3 s: 1 model(s), "
                        "47 of 47 images registered; pose verification "
                        "re-placed 2 and left out 1 image(s).\nWrote 30 "
                        "images, 1 cameras, 900 points, 400 verified "
                        "pairs\n")
            self.assertEqual(parse.parse_finish(path), {
                "mapper_seconds": 12.3, "models": 1, "replaced_images": 2,
                "left_out_images": 1})
            self.assertEqual(parse.parse_generator_summary(path),
                             {"points": 900, "verified_pairs": 400})

    def test_stages_of_a_record(self):
        record = {"stages": [["a", 1.0], ["b", 2.0], ["a", 0.5]]}
        self.assertEqual(parse.stage_times(record), {"a": 1.5, "b": 2.0})
        self.assertEqual(parse.merged_stages(record),
                         [("a", 1.5), ("b", 2.0)])
        self.assertEqual(parse.stage_order([{}, record]), ["a", "b"])


def append(path, text):
    with open(path, "a") as f:
        f.write(text)


class StageTrackerTest(unittest.TestCase):
    def test_log_written_in_pieces(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "log.txt")
            tracker = parse.StageTracker(path)
            self.assertEqual(tracker.poll(), (parse.STARTUP, False),
                             "no log yet")
            append(path, "I1201 12:00:00.1 global_mapper.cc:28] Stage "
                   "Database ...\nI1201 12:00:00.2 x.cc:1] Reading\n"
                   "I1201 Stage Rotation aver")
            self.assertEqual(tracker.poll(), ("database", True),
                             "a begin line")
            append(path, "aging ...\n")
            self.assertEqual(tracker.poll(), ("rotation_averaging", True),
                             "a line completed by the next write")
            self.assertEqual(tracker.poll(), ("rotation_averaging", False),
                             "nothing new")
            self.assertEqual(parse.unfinished_stage(path),
                             "rotation_averaging")
            append(path, "I1201 global_mapper.cc:38] Stage Rotation "
                   "averaging: 1.250 s (images=5)\n")
            self.assertEqual(tracker.poll(), (None, True), "an end line")
            append(path, "I1201 Stage Tracks ...\nI1201 Stage Tracks: 0.500 "
                   "s (tracks=3)\nI1201 Stage Global positioning: 2 s\n"
                   "I1201 Stage Bundle adjustment ...\n")
            self.assertEqual(tracker.poll(), ("bundle_adjustment", True),
                             "several lines at once")
            # The same log through parse_stages.
            self.assertEqual(parse.parse_stages(path),
                             [["rotation_averaging", 1.25], ["tracks", 0.5],
                              ["global_positioning", 2.0]])


if __name__ == "__main__":
    unittest.main()
