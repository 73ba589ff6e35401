"""Cached synthetic scenes: a scene folder holds a stamp of what made it (the
generator's options and the sha256 of make_synthetic_scene); a scene whose
stamp differs is generated anew."""

import json
import os

from glomap_bench import provenance

# Stamp of a cached synthetic scene, inside its folder.
SCENE_STAMP = "benchmark_stamp.json"


def generator_path(colmap):
    """make_synthetic_scene beside the colmap binary."""
    return os.path.join(os.path.dirname(os.path.abspath(colmap)),
                        "make_synthetic_scene")


def scene_stamp(tool, options):
    """What a cached scene depends on: the generator's options and a
    fingerprint of the generator binary (sha256; size and mtime for the
    reader)."""
    stat = os.stat(tool)
    return {"generator": os.path.abspath(tool), "options": list(options),
            "sha256": provenance.file_sha256(tool), "size": stat.st_size,
            "mtime": int(stat.st_mtime)}


def read_stamp(path):
    """The stamp (a dict) at path; None if missing or unreadable."""
    try:
        with open(path) as f:
            stamp = json.load(f)
        return stamp if isinstance(stamp, dict) else None
    except (OSError, ValueError):
        return None


def write_stamp(path, stamp):
    """Writes the stamp; called last, so that an interrupted generation
    leaves no stamp."""
    with open(path, "w") as f:
        json.dump(stamp, f, indent=2)


def stamp_matches(old, new):
    """Whether a cached scene's stamp (None: none) still fits: the same
    options and the same generator binary (by content; its path, size and
    mtime are only for the reader)."""
    return (old is not None and old.get("options") == new["options"]
            and old.get("sha256") == new["sha256"])


def stale_reason(old, options):
    """Why a cached scene with stamp `old` (None: none) that does not match
    is made anew: "no stamp", "other options" or "other generator"."""
    if old is None:
        return "no stamp"
    if old.get("options") != options:
        return "other options"
    return "other generator"
