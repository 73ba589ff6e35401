#!/usr/bin/env python3
"""Checks that src/glomap's includes run one way (src/glomap/README.md):
a file includes only headers of its own folder or of a lower one, and
every source file lies in one of the known folders. Run by ctest."""

import os
import re
import sys
import unittest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
GLOMAP = os.path.join(ROOT, "src", "glomap")
# Lowest first; a folder's subfolders share its rank.
ORDER = ["util", "scene", "io", "priors", "processors", "estimators",
         "controllers"]
INCLUDE = re.compile(r'^\s*#\s*include\s+"glomap/([^"]+)"', re.MULTILINE)


def rank_of(relative_path):
    """The rank in ORDER of the folder holding relative_path (under
    src/glomap), or None when it lies in no known folder."""
    top = relative_path.split("/")[0]
    return ORDER.index(top) if top in ORDER else None


def source_files():
    """Paths (relative to src/glomap) of every .h and .cc file."""
    for directory, _, names in os.walk(GLOMAP):
        for name in sorted(names):
            if name.endswith((".h", ".cc")):
                yield os.path.relpath(os.path.join(directory, name), GLOMAP)


def layering_errors(files_and_texts):
    """One message per file outside the folders, per include of a header
    that does not exist, and per include from a lower folder of a higher
    one. files_and_texts: (path relative to src/glomap, text) pairs."""
    known = {path for path, _ in files_and_texts}
    errors = []
    for path, text in files_and_texts:
        rank = rank_of(path)
        if rank is None or "/" not in path:
            errors.append("%s is in no folder of %s" % (path, ORDER))
            continue
        for included in INCLUDE.findall(text):
            if included not in known:
                errors.append("%s includes glomap/%s, which does not exist"
                              % (path, included))
            elif rank_of(included) > rank:
                errors.append("%s (%s) includes glomap/%s (%s), a higher "
                              "folder" % (path, ORDER[rank], included,
                                          ORDER[rank_of(included)]))
    return errors


class IncludeOrderTest(unittest.TestCase):

    def test_the_sources_follow_the_order(self):
        files = []
        for path in source_files():
            with open(os.path.join(GLOMAP, path), encoding="utf-8") as f:
                files.append((path, f.read()))
        self.assertGreater(len(files), 40)
        self.assertEqual(layering_errors(files), [])

    def test_an_upward_include_is_reported(self):
        files = [("util/a.h", '#include "glomap/scene/b.h"\n'),
                 ("scene/b.h", '#include "glomap/util/a.h"\n')]
        errors = layering_errors(files)
        self.assertEqual(len(errors), 1)
        self.assertIn("util/a.h (util) includes glomap/scene/b.h", errors[0])

    def test_a_file_outside_the_folders_and_a_missing_header_are_reported(
            self):
        files = [("loose.h", ""),
                 ("processors/c.cc", '#include "glomap/util/missing.h"\n')]
        errors = layering_errors(files)
        self.assertEqual(len(errors), 2)
        self.assertIn("loose.h is in no folder", errors[0])
        self.assertIn("does not exist", errors[1])


if __name__ == "__main__":
    unittest.main()
