#!/usr/bin/env python3
"""Tests of glomap_bench.scale_runs: the generator's and the mapper's
commands, what makes two runs the same, the layouts option, the lines
printed after a run."""

import argparse
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, scale_runs  # noqa: E402


class CommandTest(unittest.TestCase):
    def test_generator_options(self):
        self.assertEqual(scale_runs.generator_options("grid", 1000, 3), [
            "--layout", "grid", "--num_images", "1000", "--verification",
            "ground_truth", "--wrong_match_ratio", "0.3",
            "--prior_focal_length", "0", "--pixel_noise_px", "1",
            "--random_seed", "3"])

    def test_command_key(self):
        self.assertEqual(scale_runs.command_key(
            ["/b/colmap", "global_mapper", "--database_path", "/x/db",
             "--output_path", "/y", "--image_path", "/z",
             "--GlobalMapper.random_seed", "0"]),
            ["global_mapper", "--GlobalMapper.random_seed", "0"])

    def test_mapper_command(self):
        args = argparse.Namespace(colmap="/b/colmap", num_threads=2,
                                  mapper_args=["--X", "1"])
        command = scale_runs.mapper_command(args, "/d", "/i", "/o", 4)
        self.assertEqual(scale_runs.command_key(command), [
            "global_mapper", "--GlobalMapper.random_seed", "4",
            "--GlobalMapper.num_threads", "2", "--X", "1"])
        self.assertEqual(scale_runs.run_name("grid", 1000, 4),
                         "grid_1000_seed4")

    def test_reference_command(self):
        # The same seed and threads, none of our --mapper_args.
        args = argparse.Namespace(reference_colmap="/u/colmap",
                                  num_threads=2, mapper_args=["--X", "1"])
        command = scale_runs.reference_command(args, "/d", "/i", "/o", 4)
        self.assertEqual(command[0], "/u/colmap")
        self.assertEqual(scale_runs.command_key(command), [
            "global_mapper", "--GlobalMapper.random_seed", "4",
            "--GlobalMapper.num_threads", "2"])


class LayoutsTest(unittest.TestCase):
    def test_layouts(self):
        self.assertEqual(scale_runs.parse_layouts("grid, ring"),
                         ["grid", "ring"])
        for text in ("", "grid,grid", "grid,moon"):
            with self.assertRaises(argparse.ArgumentTypeError):
                scale_runs.parse_layouts(text)


class SummaryLinesTest(unittest.TestCase):
    def test_lines_after_a_run(self):
        record = fixtures.scale_record("grid", 1000)
        lines = scale_runs.run_summary_lines(record)
        self.assertEqual(lines[0], "  ok, 1.82 s, peak 95 MB, 1000/1000 "
                         "registered, AUC@1/3/5 50.0/80.0/90.0, median "
                         "rotation error 0.012 deg")
        self.assertEqual(lines[1], "  stages: database 1.00 s/63 MB, "
                         "rotation_averaging 0.32 s/95 MB, "
                         "camera_clustering 0.00 s/– MB")


if __name__ == "__main__":
    unittest.main()
