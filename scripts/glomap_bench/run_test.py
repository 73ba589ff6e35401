#!/usr/bin/env python3
"""Tests of glomap_bench.run: memory per stage from samples, and measured
runs of small Python children (their own peak memory, stages, a timeout, a
stop request, a killed child)."""

import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import parse, run, tables  # noqa: E402
from glomap_bench.parse import OTHER, STARTUP  # noqa: E402

# A child that allocates argv[1] MB inside a stage, holds it argv[2] s and
# exits with argv[3].
CHILD = ("import sys, time\n"
         "print('Stage Big ...', flush=True)\n"
         "block = bytearray(int(sys.argv[1]) * 1024 * 1024)\n"
         "for k in range(0, len(block), 4096): block[k] = 1\n"
         "time.sleep(float(sys.argv[2]))\n"
         "print('Stage Big: 0.1 s (x=1)', flush=True)\n"
         "del block\n"
         "sys.exit(int(sys.argv[3]))\n")


class StageMemoryTest(unittest.TestCase):
    def test_peaks_per_stage(self):
        peaks, counts = run.stage_memory([
            (STARTUP, False, 5.0, 5.0),
            (None, True, 10.0, 10.0),
            ("database", True, 50.0, 60.0),
            ("database", False, 40.0, 80.0),   # peak 80 inside the stage
            ("tracks", True, 30.0, 95.0),      # rise across a stage line
            ("tracks", False, 35.0, 95.0),
            (None, True, 20.0, 95.0),
            (None, True, 25.0, 99.0),          # a stage line in between
        ])
        self.assertEqual(peaks, {STARTUP: 5.0, OTHER: 25.0, "database": 80.0,
                                 "tracks": 35.0})
        self.assertEqual(counts, {STARTUP: 1, OTHER: 3, "database": 2,
                                  "tracks": 2})


class MeasureProcessTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.log_path = os.path.join(self.dir.name, "log.txt")
        # From a file: the log's first line is the command.
        self.child = os.path.join(self.dir.name, "child.py")
        with open(self.child, "w") as f:
            f.write(CHILD)

    def tearDown(self):
        self.dir.cleanup()

    def measure(self, mb, sleep_s, code, timeout_s=None, interval_s=0.05):
        return run.measure_process(
            [sys.executable, self.child, str(mb), str(sleep_s), str(code)],
            self.log_path, timeout_s, interval_s)

    def test_own_peak_of_each_child(self):
        # A 300 MB child first must not raise the next one's peak.
        big = self.measure(300, 0.3, 0)
        small = self.measure(20, 0.5, 3)
        self.assertGreaterEqual(big["peak_rss_mb"], 300, big)
        self.assertEqual(big["exit_code"], 0)
        self.assertEqual(run.process_status(big, 1), "ok")
        self.assertLess(small["peak_rss_mb"], 150,
                        "the small child's own peak, not the big one's")
        self.assertEqual(small["exit_code"], 3)
        self.assertEqual(run.process_status(small, 1), "failed: exit 3")
        self.assertEqual(run.shell_exit_code(small), 3)
        self.assertGreaterEqual(small["stage_peak_rss_mb"].get("big", 0),
                                20, "memory sampled in the stage")
        self.assertGreaterEqual(small["stage_rss_samples"].get("big", 0), 1)
        self.assertEqual(parse.parse_stages(self.log_path), [["big", 0.1]])
        self.assertTrue(tables.read_text(self.log_path).startswith("$ "),
                        "the log holds the command and the output")
        self.assertEqual(run.last_lines(self.log_path, 1),
                         ["Stage Big: 0.1 s (x=1)"])

    def test_timeout(self):
        slow = self.measure(1, 30, 0, timeout_s=0.5)
        self.assertTrue(slow["timed_out"])
        self.assertEqual(run.process_status(slow, 1), "timeout after 1 s")
        self.assertLess(slow["wall_s"], 20)

    def test_a_stop_request(self):
        run.STOP.set()
        try:
            stopped = self.measure(1, 30, 0)
        finally:
            run.STOP.clear()
        self.assertTrue(stopped["interrupted"])
        self.assertEqual(run.process_status(stopped, 1), "interrupted")
        self.assertLess(stopped["wall_s"], 20)

    def test_the_end_is_not_rounded_up_to_the_next_sample(self):
        quick = run.measure_process([sys.executable, "-c", "pass"],
                                    self.log_path, None, 5.0)
        self.assertEqual(quick["exit_code"], 0)
        self.assertLess(quick["wall_s"], 4.0)

    def test_a_killed_child(self):
        killed = run.measure_process(
            [sys.executable, "-c", "import os, signal; "
             "os.kill(os.getpid(), signal.SIGKILL)"],
            self.log_path, None, 0.05)
        self.assertEqual(run.process_status(killed, 1),
                         "killed by SIGKILL (out of memory?)")
        self.assertIsNone(killed["exit_code"])
        self.assertEqual(run.shell_exit_code(killed), 137,
                         "128 + 9, as a shell and GNU time report it")


class CaptureTest(unittest.TestCase):
    def test_capture(self):
        self.assertEqual(run.capture([sys.executable, "-c",
                                      "print('out'); exit(2)"]),
                         (2, "out\n"))


if __name__ == "__main__":
    unittest.main()
