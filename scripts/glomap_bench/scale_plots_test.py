#!/usr/bin/env python3
"""Tests of glomap_bench.scale_plots on made-up runs: the plot data and the
gnuplot scripts (gnuplot itself is not needed)."""

import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import fixtures, scale_plots, scale_summary  # noqa: E402
from glomap_bench.parse import OTHER  # noqa: E402


class PlotTest(unittest.TestCase):
    def setUp(self):
        self.names, self.data = scale_plots.plot_series(
            scale_summary.layout_rows(fixtures.scale_records(), "forward"))

    def test_plot_data(self):
        self.assertEqual(self.names, ["database", "rotation_averaging",
                                      "camera_clustering", OTHER])
        self.assertEqual(len(self.data), 3, "the timed-out size is left out")
        self.assertEqual(self.data[0].split(), [
            "1000", "1", "0.316228", "0.00158489", "0.5", "1.81781",
            "63.2456", "94.8683", "?", "31.6228", "94.8683"])

    def test_time_plot_script(self):
        script = scale_plots.plot_script(
            [("survey", "/o/a.dat", self.names, (1000, 2.0)),
             ("street", "/o/b.dat", self.names, None)],
            "/o/time.png", "time", fixtures.SIZES)
        self.assertIn("set logscale xy", script)
        self.assertIn("set output '/o/time.png'", script)
        self.assertIn("set multiplot layout 1,2", script)
        self.assertEqual(script.count("'/o/a.dat' using 1:"), 5)
        self.assertIn("'/o/a.dat' using 1:6 with linespoints lw 3", script)
        self.assertEqual(script.count("x**1.2"), 1)
        self.assertIn("set xtics ('1000' 1000, '2000' 2000, '5000' 5000, "
                      "'10000' 10000)", script)

    def test_memory_plot_script(self):
        script = scale_plots.plot_script(
            [("survey", "/o/a.dat", self.names, (1000, 2.0))],
            "/o/m.png", "memory", fixtures.SIZES)
        self.assertIn("'/o/a.dat' using 1:7 with", script)
        self.assertIn("'/o/a.dat' using 1:11 with linespoints lw 3", script)
        self.assertIn("title 'whole process'", script)

    def test_png_terminal_without_cairo(self):
        script = scale_plots.plot_script(
            [("survey", "/o/a.dat", self.names, None)], "/o/m.png",
            "memory", fixtures.SIZES, pngcairo=False)
        self.assertTrue(script.startswith("set terminal png size 900,720\n"))


if __name__ == "__main__":
    unittest.main()
