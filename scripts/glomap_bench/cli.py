"""The entry scripts' options: argument types, and --self_test, which runs
this package's tests."""

import argparse
import os
import sys
import unittest


def int_list(text):
    """Argument type: distinct non-negative integers, comma-separated
    ("0,1,2" -> [0, 1, 2])."""
    try:
        values = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError("not a list of integers: %r" % text)
    if not values or len(set(values)) != len(values) or min(values) < 0:
        raise argparse.ArgumentTypeError(
            "need distinct non-negative integers: %r" % text)
    return values


def positive_int(text):
    """Argument type: an integer of at least 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError("need a positive integer: %r" % text)
    return value


def run_self_tests(verbosity=1):
    """Runs every <module>_test.py of this package; whether all passed."""
    package_dir = os.path.dirname(os.path.abspath(__file__))
    suite = unittest.defaultTestLoader.discover(
        package_dir, pattern="*_test.py",
        top_level_dir=os.path.dirname(package_dir))
    result = unittest.TextTestRunner(verbosity=verbosity).run(suite)
    return result.wasSuccessful()


def main(parser, run_benchmark):
    """An entry script's main: parses the options of parser (which has
    --self_test); with --self_test runs the package's tests and exits (1 if
    one failed), else calls run_benchmark(options)."""
    args = parser.parse_args()
    if args.self_test:
        sys.exit(0 if run_self_tests() else 1)
    run_benchmark(args)
