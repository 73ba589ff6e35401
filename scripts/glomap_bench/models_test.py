#!/usr/bin/env python3
"""Tests of glomap_bench.models on files made here: a model's image names
(binary and text), the model folder check, a database's image count."""

import os
import sqlite3
import struct
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import models  # noqa: E402


class ImageNamesTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.path = self.dir.name

    def tearDown(self):
        self.dir.cleanup()

    def test_images_bin(self):
        with open(os.path.join(self.path, "images.bin"), "wb") as f:
            f.write(struct.pack("<Q", 2))
            for k, (name, points) in enumerate([("a b.jpg", 2),
                                                ("c.png", 0)]):
                f.write(struct.pack("<I7dI", k + 1, 1, 0, 0, 0, 0, 0, 0, 1))
                f.write(name.encode() + b"\0" + struct.pack("<Q", points))
                f.write(struct.pack("<ddq", 1, 2, -1) * points)
        self.assertEqual(models.read_image_names("colmap", self.path),
                         {"a b.jpg", "c.png"})

    def test_images_txt_with_an_empty_line(self):
        path = os.path.join(self.path, "images.txt")
        with open(path, "w") as f:
            f.write("# Image list\n# two lines\n"
                    "1 1 0 0 0 0 0 0 1 a b.jpg\n1.0 2.0 -1\n"
                    "2 1 0 0 0 0 0 0 1 c.png\n\n")
        self.assertEqual(set(models.read_image_names_txt(path)),
                         {"a b.jpg", "c.png"})
        self.assertEqual(models.read_image_names("colmap", self.path),
                         {"a b.jpg", "c.png"})

    def test_images_txt_with_many_points(self):
        path = os.path.join(self.path, "images.txt")
        with open(path, "w") as f:
            f.write("1 1 0 0 0 0 0 0 1 a.jpg\n" + "1.0 2.0 -1 " * 4 + "\n")
        self.assertEqual(models.read_image_names_txt(path), ["a.jpg"])

    def test_no_model(self):
        self.assertIsNone(models.read_image_names("colmap", self.path))
        self.assertIsNone(models.read_image_names("colmap", None))
        self.assertFalse(models.is_model_dir(self.path))
        for name in ("cameras", "images", "points3D"):
            open(os.path.join(self.path, name + ".txt"), "w").close()
        self.assertTrue(models.is_model_dir(self.path))


class DatabaseTest(unittest.TestCase):
    def test_count_db_images(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "database.db")
            connection = sqlite3.connect(path)
            connection.execute("CREATE TABLE images (image_id INTEGER)")
            connection.executemany("INSERT INTO images VALUES (?)",
                                   [(1,), (2,), (3,)])
            connection.commit()
            connection.close()
            self.assertEqual(models.count_db_images(path), 3)
            empty = os.path.join(tmp, "empty.db")
            self.assertIsNone(models.count_db_images(empty))


if __name__ == "__main__":
    unittest.main()
