#!/usr/bin/env python3
"""Tests of glomap_bench.provenance: the quoted command, CMakeCache.txt,
binaries without a build tree, the report's first lines."""

import hashlib
import os
import shlex
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, provenance  # noqa: E402


class CommandTest(unittest.TestCase):
    def test_quoted_command(self):
        argv = ["scripts/benchmark.py", "--readme", "/tmp/a b/README.md",
                "--synthetic", "30", "--reference_colmap=build/bin/colmap",
                "it's"]
        command, cwd = provenance.format_command(argv, "/work/main")
        self.assertEqual(command, "python3 scripts/benchmark.py --readme "
                         "'/tmp/a b/README.md' --synthetic 30 "
                         "--reference_colmap=build/bin/colmap "
                         "'it'\"'\"'s'")
        self.assertEqual(shlex.split(command)[1:], argv)
        self.assertEqual(cwd, "/work/main")

    def test_a_command_that_is_no_script(self):
        self.assertEqual(provenance.format_command(["/x/bench", "a b"],
                                                   "/")[0],
                         "/x/bench 'a b'")


class BuildTest(unittest.TestCase):
    def test_cmake_cache(self):
        self.assertEqual(provenance.parse_cmake_cache(
            "# c\nCMAKE_BUILD_TYPE:STRING=Release\n"
            "CMAKE_HOME_DIRECTORY:INTERNAL=/src\n"), ("Release", "/src"))

    def test_no_build_type(self):
        self.assertEqual(provenance.parse_cmake_cache(
            "CMAKE_BUILD_TYPE:STRING=\n"), ("unknown", None))

    def test_a_binary_without_cmake_cache(self):
        self.assertEqual(provenance.binary_info(
            "/nonexistent/bin/colmap")["build_type"], "unknown")

    def test_not_a_git_tree_and_sha256(self):
        with tempfile.TemporaryDirectory() as tmp:
            self.assertIsNone(provenance.git_commit(tmp))
            path = os.path.join(tmp, "tool")
            with open(path, "wb") as f:
                f.write(b"generator v1")
            self.assertEqual(provenance.file_sha256(path),
                             hashlib.sha256(b"generator v1").hexdigest())


class ProvenanceLinesTest(unittest.TestCase):
    def test_header(self):
        meta = fixtures.benchmark_meta()
        header = provenance.provenance_lines(meta)
        self.assertEqual(header[0], "Command: `%s` (in `/work/main`)." %
                         meta["command"])
        self.assertIn("commit abc1234+dirty of `/r`", header[1])
        self.assertIn("ours `/r/build/bin/colmap` (Release)", header[1])
        self.assertIn("reference `/u/build/bin/colmap` (unknown, source "
                      "unknown)", header[1])
        self.assertEqual(header[2], "Machine: Test CPU @ 2.0GHz, 2 cores, "
                         "23.5 GiB memory, Linux 6.1.0; today.")
        self.assertEqual(len(header), 3)


if __name__ == "__main__":
    unittest.main()
