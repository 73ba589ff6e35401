#!/usr/bin/env python3
"""Side-by-side benchmark of our `colmap global_mapper` and COLMAP's stock
incremental `mapper` (and, with --reference_colmap, another COLMAP build's
`global_mapper`, e.g. upstream COLMAP 4.x).

For every dataset folder (a `database.db`, optionally an `images/` folder and a
ground-truth model in `gt/`), the mappers run one after the other, each run on
its own copy of the database in a fresh output folder. With --repeats N every
mapper runs N times per input, alternating (ours, stock, reference, ours,
stock, ...) so that a change of the machine's load hits all of them alike; the
table shows the median wall time with its spread (min-max) and the medians of
the other figures. Recorded per run: wall time (and, for the global
mapper, the time of each stage from its log lines `Stage <name>: <seconds> s`),
peak memory, registered images, mean reprojection error and mean track length
(`colmap model_analyzer`), and the ground-truth metrics (`colmap
model_evaluator`: pairwise pose AUC at 0.5/1/3/5/10 degrees -- 0.5 only
with an evaluator that has --pose_thresholds --, camera position errors).

With --seeds, our global mapper runs once per seed
(`--GlobalMapper.random_seed`); the stock mapper runs once per dataset. The
main table then shows, for ours, the median over all its runs (seeds x
repeats) and the spread.

The reports start with the provenance: the exact command (shell-quoted
sys.argv) and its working folder, the source commit (+dirty with changes to
tracked files), build type (CMAKE_BUILD_TYPE of the CMakeCache.txt beside the
binary's bin/ folder) and path of each binary, and the machine (CPU model,
cores, memory, kernel).

Synthetic scenes (--synthetic N) are cached under <output_dir>/scenes/ with a
stamp file (the generator's options and the sha256 of make_synthetic_scene);
a scene whose stamp differs is generated anew.

A "bars" table checks every run of ours against the acceptance bars of issue
10: all images registered; AUC@3 at least the better of the reference mappers'
figures in the dataset's README minus 0.5; no registered camera farther than
5% of the scene size from ground truth (`cameras_beyond` of model_evaluator);
KITTI_sequence_1 a mean position error of at most 0.02 m. On a dataset whose
README has the stock `mapper` but no upstream `global_mapper` figures
(dino-363), or one named by --stock_relative, the bars are relative to the
stock mapper of the same benchmark run instead: every image it registers is
registered by ours, AUC@3 at most 1 point below it, at most half its time
(the README's stock figures stand in when the stock mapper was skipped).

Camera setups (--camera_setup): the databases as they are ("database"), or
rewritten by scripts/rewrite_cameras.py into <output_dir>/camera_setups/ the
way a user's project often has them: one shared camera ("shared"), one camera
per image without a focal prior ("per_image", feature_extractor's default
without EXIF), or one per image with an EXIF-like focal --exif_error off the
ground truth ("per_image_exif"), each of --camera_model. Every mapper runs on
the same rewritten copy; the main table's "cameras" column names the setup,
and the bars are judged against the stock mapper of the same run (the
READMEs' reference figures are for the databases as they are).

Writes to --output_dir: results.json, results.md (Markdown tables),
runtime_per_stage.png and auc_per_dataset.png (gnuplot). With --readme, also
replaces the benchmark section of the README and copies the AUC plot next to
it.

Regenerate the README's figures with:
    python3 scripts/benchmark.py --seeds 0,1,2,3,4 --readme README.md

This script parses the options; the benchmark is the package
scripts/glomap_bench/ (side_by_side and the modules it calls). --self_test
runs the package's tests (no colmap needed), like ctest does.

Only the Python standard library is used (gnuplot draws the plots).
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from glomap_bench import DEFAULT_COLMAP, cli  # noqa: E402
from glomap_bench import datasets, mappers, side_by_side  # noqa: E402


def build_parser():
    """The options of the benchmark."""
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("datasets", nargs="*",
                        help="dataset folders (database.db, optionally images/ "
                        "and gt/), or folders of them; default: every dataset "
                        "under %s" % datasets.DEFAULT_DATASETS)
    parser.add_argument("--colmap", default=DEFAULT_COLMAP,
                        help="our colmap binary (default: %(default)s)")
    parser.add_argument("--reference_colmap", metavar="PATH",
                        help="another COLMAP build's colmap binary (e.g. "
                        "upstream COLMAP 4.x); its `global_mapper` runs as a "
                        "third mapper on a copy of each database (never the "
                        "original: a newer COLMAP may migrate the schema), "
                        "evaluated like ours; fails at once if it has no "
                        "global_mapper")
    parser.add_argument("--output_dir", default=side_by_side.DEFAULT_OUTPUT,
                        help="where runs and reports go; synthetic scenes "
                        "are cached in its scenes/ (default: %(default)s)")
    parser.add_argument("--repeats", type=cli.positive_int, metavar="N",
                        help="run every mapper N times on every input, "
                        "alternating between the mappers (ours, stock, "
                        "reference, ours, ...), each run from a fresh output "
                        "folder; the table shows the median wall time with "
                        "its min-max and the medians of the other figures. "
                        "Default: %d for the datasets, %d for synthetic "
                        "scenes (--synthetic: large scenes take minutes per "
                        "run, and a scene's noise is fixed by the generator); "
                        "N given applies to both" % (
                            mappers.DEFAULT_REPEATS,
                            mappers.DEFAULT_SYNTHETIC_REPEATS))
    parser.add_argument("--seeds", type=cli.int_list, default=[0],
                        metavar="S,S,...", help="run our global mapper once "
                        "per seed (--GlobalMapper.random_seed) in every "
                        "repeat, e.g. 0,1,2,3,4; the other mappers run once "
                        "per repeat (default: 0)")
    parser.add_argument("--synthetic", type=int, action="append", default=[],
                        metavar="N", help="also a synthetic scene of N images "
                        "(make_synthetic_scene beside --colmap), cached under "
                        "<output_dir>/scenes/ and generated anew when the "
                        "generator binary or its options change; may repeat")
    parser.add_argument("--skip_incremental", action="store_true",
                        help="do not run the stock incremental mapper")
    parser.add_argument("--skip_global", action="store_true",
                        help="do not run our global mapper")
    parser.add_argument("--stock_relative", action="append", default=[],
                        metavar="DATASET", help="judge this dataset (folder "
                        "name) against the stock mapper of this run, like "
                        "dino-363; may repeat")
    parser.add_argument("--camera_setup", choices=datasets.CAMERA_SETUPS,
                        default="database", help="run every mapper on the "
                        "databases as they are (default), or on copies "
                        "rewritten to one shared camera, one camera per image "
                        "without focal prior, or one per image with an "
                        "EXIF-like prior (scripts/rewrite_cameras.py); bars "
                        "then relative to the stock mapper")
    parser.add_argument("--camera_model", default="SIMPLE_RADIAL",
                        help="camera model of a rewritten setup (default: "
                        "%(default)s)")
    parser.add_argument("--exif_error", type=float, default=0.02,
                        help="per_image_exif: the EXIF focal is off the "
                        "ground truth by up to this fraction (default: "
                        "%(default)s)")
    parser.add_argument("--position_thresholds", default="0.01,0.05,0.1",
                        help="distance thresholds of the position AUC, in "
                        "ground-truth units (default: %(default)s)")
    parser.add_argument("--timeout", type=int, default=3600,
                        help="seconds before a run is stopped (default: "
                        "%(default)s)")
    parser.add_argument("--readme", metavar="README.md",
                        help="also put the tables and the AUC plot into this "
                        "README's benchmark section")
    parser.add_argument("--self_test", action="store_true",
                        help="check the script's parsing and bars on made-up "
                        "input, then exit")
    return parser


def main():
    cli.main(build_parser(), side_by_side.run_benchmark)


if __name__ == "__main__":
    main()
