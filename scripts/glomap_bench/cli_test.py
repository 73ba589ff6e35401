#!/usr/bin/env python3
"""Tests of glomap_bench.cli: the argument types of the entry scripts."""

import argparse
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import cli  # noqa: E402


class ArgumentTypeTest(unittest.TestCase):
    def test_int_list(self):
        self.assertEqual(cli.int_list("0,1, 2,"), [0, 1, 2])
        for text in ("", "1,1", "-1", "a"):
            with self.assertRaises(argparse.ArgumentTypeError):
                cli.int_list(text)

    def test_positive_int(self):
        self.assertEqual(cli.positive_int("3"), 3)
        for text in ("0", "x"):
            with self.assertRaises(argparse.ArgumentTypeError):
                cli.positive_int(text)


if __name__ == "__main__":
    unittest.main()
