#!/usr/bin/env python3
"""Tests of glomap_bench.scenes: when a cached synthetic scene's stamp still
fits (the generator's options and content) and when not."""

import hashlib
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import datasets, scenes  # noqa: E402


class StampTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.tool = os.path.join(self.dir.name, "make_synthetic_scene")
        with open(self.tool, "wb") as f:
            f.write(b"generator v1")
        self.stamp = scenes.scene_stamp(self.tool,
                                        datasets.synthetic_options(30))
        self.stamp_path = os.path.join(self.dir.name, scenes.SCENE_STAMP)
        scenes.write_stamp(self.stamp_path, self.stamp)
        self.old = scenes.read_stamp(self.stamp_path)

    def tearDown(self):
        self.dir.cleanup()

    def test_stamp(self):
        self.assertEqual(self.stamp["sha256"],
                         hashlib.sha256(b"generator v1").hexdigest())
        self.assertEqual(self.stamp["options"], ["--num_images", "30"])

    def test_the_same_stamp_matches(self):
        self.assertTrue(scenes.stamp_matches(self.old, self.stamp))

    def test_a_copied_touched_generator_with_the_same_content_matches(self):
        self.assertTrue(scenes.stamp_matches(
            dict(self.old, mtime=0, generator="/x"), self.stamp))

    def test_no_stamp(self):
        self.assertFalse(scenes.stamp_matches(None, self.stamp))
        self.assertIsNone(scenes.read_stamp(os.path.join(self.dir.name,
                                                         "missing")))
        self.assertEqual(scenes.stale_reason(None, []), "no stamp")

    def test_other_options(self):
        other = scenes.scene_stamp(self.tool,
                                   datasets.synthetic_options(2000))
        self.assertFalse(scenes.stamp_matches(self.old, other))
        self.assertEqual(scenes.stale_reason(self.old, other["options"]),
                         "other options")

    def test_another_generator(self):
        with open(self.tool, "wb") as f:
            f.write(b"generator v2")
        options = datasets.synthetic_options(30)
        self.assertFalse(scenes.stamp_matches(
            self.old, scenes.scene_stamp(self.tool, options)))
        self.assertEqual(scenes.stale_reason(self.old, options),
                         "other generator")

    def test_generator_beside_colmap(self):
        self.assertEqual(scenes.generator_path("/b/bin/colmap"),
                         "/b/bin/make_synthetic_scene")


if __name__ == "__main__":
    unittest.main()
