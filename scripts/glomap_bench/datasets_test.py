#!/usr/bin/env python3
"""Tests of glomap_bench.datasets: finding dataset folders, the camera
setups' labels and rewrite commands, the synthetic scenes' options."""

import argparse
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import datasets  # noqa: E402


class CameraSetupTest(unittest.TestCase):
    def test_labels(self):
        self.assertEqual(datasets.camera_setup_label(
            "per_image_exif", "OPENCV", 0.02), "per image OPENCV, EXIF 2% off")
        self.assertEqual(datasets.camera_setup_label(
            "shared", "PINHOLE", 0.02), "shared PINHOLE, no prior")
        self.assertEqual(datasets.camera_setup_label(
            "database", "PINHOLE", 0.02), "as in the database")

    def test_rewrite_command(self):
        args = argparse.Namespace(camera_setup="per_image_exif",
                                  camera_model="OPENCV", exif_error=0.02)
        command = datasets.rewrite_cameras_command(args, "/d", "/o/db")
        self.assertTrue(command[1].endswith("scripts/rewrite_cameras.py"))
        self.assertEqual(command[2:], [
            "--database_path", "/d/database.db", "--output_path", "/o/db",
            "--camera_mode", "per_image", "--camera_model", "OPENCV",
            "--focal", "exif", "--gt_path", "/d/gt", "--exif_error", "0.02"])


class InputsTest(unittest.TestCase):
    def test_find_datasets(self):
        with tempfile.TemporaryDirectory() as tmp:
            for name in ("b", "a", "c"):
                os.makedirs(os.path.join(tmp, name))
                if name != "c":
                    open(os.path.join(tmp, name, "database.db"), "w").close()
            self.assertEqual(datasets.find_datasets([tmp]), [
                os.path.join(tmp, "a"), os.path.join(tmp, "b")])
            self.assertEqual(datasets.find_datasets(
                [os.path.join(tmp, "b")]), [os.path.join(tmp, "b")])

    def test_synthetic_options(self):
        self.assertEqual(datasets.synthetic_options(30),
                         ["--num_images", "30"])
        self.assertIn("ground_truth", datasets.synthetic_options(2000))


if __name__ == "__main__":
    unittest.main()
