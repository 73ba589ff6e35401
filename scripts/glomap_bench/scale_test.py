"""Tests of scale.py's --resume bookkeeping."""

import argparse
import tempfile
import unittest

from glomap_bench import scale, scale_runs


class KeptElsewhereTest(unittest.TestCase):
    def setUp(self):
        self.work = tempfile.mkdtemp()
        self.args = argparse.Namespace(
            colmap="/bin/colmap", num_threads=2, mapper_args=["--x", "1"],
            colmap_sha256="abc", reference_colmap=None,
            reference_colmap_sha256=None)

    def record(self, layout, images, seed, **changes):
        key = scale_runs.command_key(
            scale_runs.mapper_command(self.args, "", "", "", seed))
        return dict({"layout": layout, "images": images, "seed": seed,
                     "status": "ok", "evaluation": {"pose_aucs": [1]},
                     "command_key": key, "colmap_sha256": "abc",
                     "work": self.work}, **changes)

    def test_keeps_unscheduled_runs_of_the_same_command(self):
        previous = [
            self.record("grid", 1000, 0),   # scheduled again: not here
            self.record("grid", 5000, 0),   # another size: kept
            self.record("forward", 2000, 0),  # another layout: kept
            self.record("grid", 10000, 0, colmap_sha256="other"),
            self.record("grid", 20000, 0, status="timeout"),
            self.record("ring", 300, 0, mapper="reference"),
        ]
        kept = scale.kept_elsewhere(self.args, previous,
                                    [(1000, "grid", 0), (2000, "grid", 0)])
        self.assertEqual([(r["layout"], r["images"]) for r in kept],
                         [("grid", 5000), ("forward", 2000)])
        self.assertTrue(all(r["resumed"] for r in kept))

    def test_other_mapper_options_are_not_kept(self):
        previous = [self.record("grid", 5000, 0)]
        self.args.mapper_args = ["--x", "2"]
        self.assertEqual(
            scale.kept_elsewhere(self.args, previous, [(1000, "grid", 0)]),
            [])


if __name__ == "__main__":
    unittest.main()
