#!/usr/bin/env python3
"""Tests of glomap_bench.tables: number formats, rows, and the replacement
of a README section."""

import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(
    __file__))))
from glomap_bench import tables  # noqa: E402


class FormatTest(unittest.TestCase):
    def test_formats(self):
        self.assertEqual(tables.fmt(None), "–")
        self.assertEqual(tables.fmt(2.345, 2, " s"), "2.35 s")
        self.assertEqual(tables.fmt_error(0.0070771), "0.007077")
        self.assertEqual(tables.fmt_deg(0.0123), "0.012")
        self.assertEqual(tables.fmt_slope(None), "–")

    def test_spans_and_ranges(self):
        self.assertEqual(tables.fmt_span([3, None, 3]), "3")
        self.assertEqual(tables.fmt_span([5, 2, None]), "2–5")
        self.assertEqual(tables.fmt_span([None]), "–")
        self.assertEqual(tables.fmt_range([4.0, 4.0]), "4.0–4.0")

    def test_rows(self):
        self.assertEqual(tables.header_rows(["a", "b"]),
                         ["| a | b |", "|---|---|"])


class ReadmeSectionTest(unittest.TestCase):
    MARKERS = ("<!-- s:begin -->", "<!-- s:end -->")

    def update(self, text, report, before=None):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "README.md")
            with open(path, "w") as f:
                f.write(text)
            tables.update_readme_section(path, report, [], self.MARKERS,
                                         "## S", before)
            return tables.read_text(path)

    def test_replaced(self):
        text = self.update("a\n<!-- s:begin -->\nold\n<!-- s:end -->\nb\n",
                           "prov\n\ntable\n")
        self.assertEqual(text, "a\n<!-- s:begin -->\n\nprov\n\ntable\n\n"
                         "<!-- s:end -->\nb\n")

    def test_inserted_before_another_section_and_its_heading(self):
        text = self.update("a\n\n## T\n\n<!-- t -->\nx\n", "prov\n\ntable",
                           before="<!-- t -->")
        self.assertEqual(text, "a\n\n## S\n\n<!-- s:begin -->\n\nprov\n\n"
                         "table\n\n<!-- s:end -->\n\n## T\n\n<!-- t -->\nx\n")

    def test_appended(self):
        text = self.update("a\n\n", "prov\n\ntable", before="<!-- t -->")
        self.assertEqual(text, "a\n\n## S\n\n<!-- s:begin -->\n\nprov\n\n"
                         "table\n\n<!-- s:end -->\n")


if __name__ == "__main__":
    unittest.main()
