#!/usr/bin/env python3
"""Tests of scripts/rewrite_cameras.py on a small database made here (the
cameras and images tables as COLMAP 3.8 writes them). Run by ctest."""

import hashlib
import os
import sqlite3
import struct
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rewrite_cameras  # noqa: E402


def make_database(path, num_images=3):
    connection = sqlite3.connect(path)
    connection.executescript(
        "CREATE TABLE cameras (camera_id INTEGER PRIMARY KEY AUTOINCREMENT "
        "NOT NULL, model INTEGER NOT NULL, width INTEGER NOT NULL, height "
        "INTEGER NOT NULL, params BLOB, prior_focal_length INTEGER NOT NULL);"
        "CREATE TABLE images (image_id INTEGER PRIMARY KEY AUTOINCREMENT NOT "
        "NULL, name TEXT NOT NULL UNIQUE, camera_id INTEGER NOT NULL);")
    connection.execute(
        "INSERT INTO cameras VALUES (1, 2, 640, 480, ?, 0)",
        (struct.pack("<4d", 768, 320, 240, 0),))
    for i in range(num_images):
        connection.execute("INSERT INTO images VALUES (?, ?, 1)",
                           (i + 1, "image%d.png" % (i + 1)))
    connection.commit()
    connection.close()


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class RewriteCamerasTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.database = os.path.join(self.dir.name, "database.db")
        make_database(self.database)

    def tearDown(self):
        self.dir.cleanup()

    def run_script(self, output, *args):
        return rewrite_cameras.main(["--database_path", self.database,
                                     "--output_path", output] + list(args))

    def test_per_image_opencv(self):
        before = digest(self.database)
        output = os.path.join(self.dir.name, "per_image.db")
        self.assertEqual(
            self.run_script(output, "--camera_model", "OPENCV"), 0)
        self.assertEqual(digest(self.database), before)
        connection = sqlite3.connect(output)
        cameras = connection.execute(
            "SELECT camera_id, model, width, height, params, "
            "prior_focal_length FROM cameras ORDER BY camera_id").fetchall()
        self.assertEqual([c[0] for c in cameras], [1, 2, 3])
        for camera in cameras:
            self.assertEqual(camera[1:4], (4, 640, 480))
            self.assertEqual(struct.unpack("<8d", camera[4]),
                             (768, 768, 320, 240, 0, 0, 0, 0))
            self.assertEqual(camera[5], 0)
        self.assertEqual(connection.execute(
            "SELECT image_id, camera_id FROM images ORDER BY image_id"
        ).fetchall(), [(1, 1), (2, 2), (3, 3)])

    def test_shared_exif(self):
        gt = os.path.join(self.dir.name, "gt")
        os.makedirs(gt)
        with open(os.path.join(gt, "cameras.txt"), "w") as f:
            f.write("# camera\n1 PINHOLE 640 480 1000 1002 320 240\n"
                    "2 PINHOLE 640 480 1000 1002 320 240\n")
        with open(os.path.join(gt, "images.txt"), "w") as f:
            for i in range(3):
                f.write("%d 1 0 0 0 0 0 0 %d image%d.png\n\n"
                        % (i + 1, 1 + i % 2, i + 1))
        output = os.path.join(self.dir.name, "shared.db")
        self.assertEqual(self.run_script(
            output, "--camera_mode", "shared", "--focal", "exif",
            "--gt_path", gt, "--exif_error", "0.02"), 0)
        connection = sqlite3.connect(output)
        cameras = connection.execute(
            "SELECT params, prior_focal_length FROM cameras").fetchall()
        self.assertEqual(len(cameras), 1)
        focal = struct.unpack("<4d", cameras[0][0])[0]
        self.assertLessEqual(abs(focal / 1001 - 1), 0.02)
        self.assertEqual(cameras[0][1], 1)

    def test_refuses_existing_output_and_bad_model(self):
        output = os.path.join(self.dir.name, "exists.db")
        open(output, "w").close()
        self.assertEqual(self.run_script(output), 1)
        self.assertEqual(os.path.getsize(output), 0)
        other = os.path.join(self.dir.name, "other.db")
        self.assertEqual(self.run_script(other, "--camera_model", "NOPE"), 1)
        self.assertFalse(os.path.exists(other))


if __name__ == "__main__":
    unittest.main()
