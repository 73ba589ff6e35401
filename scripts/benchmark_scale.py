#!/usr/bin/env python3
"""Scale benchmark of our `colmap global_mapper` on synthetic scenes (issue
14): how the time and the memory of every stage grow with the number of
images.

For every size (--sizes, default 1,000, 2,000, 5,000 and 10,000 images),
layout (--layouts: `grid`, the aerial survey, and `forward`, a long street
driven forward with one image per metre) and seed (--seeds), the synthetic
generator (make_synthetic_scene beside --colmap) writes a scene with unknown
focal length (--prior_focal_length 0), 1 px keypoint noise, 30% wrong raw
matches and ground-truth two-view verification, and the mapper runs on it
once, from a fresh output folder. Recorded per run:
  - the wall time of every stage, from the mapper's log lines
    `Stage <name>: <seconds> s (...)`, "other" (the wall time outside the
    stages: start-up, writing the models) and the total wall time of the
    mapper process;
  - the peak resident memory of the mapper process itself: the ru_maxrss of
    os.wait4() on its pid (that child's own rusage, not the maximum over all
    children of this script, which RUSAGE_CHILDREN would give after a larger
    generator run), or the largest sample below if that is higher (the
    kernel's RSS counters lag by up to a few hundred kB);
  - the peak resident memory per stage: VmRSS of /proc/<pid>/status sampled
    every --sample_interval_s seconds, each sample attributed to the stage
    that is running (from the mapper's `Stage <name> ...` and `Stage <name>:
    ...` lines, read from its log as they appear); when the process's
    high-water mark (VmHWM) rises between two samples of the same stage with
    no stage line in between, that mark counts for the stage too. Samples
    between and after the stages go to "other" (those before the first
    stage, "start-up", only to results.json). A stage shorter than the
    interval may get no sample ("–"); the whole-process peak is exact in
    any case;
  - registered images, the pairwise pose AUC at 1/3/5 degrees and the median
    rotation error of `colmap model_evaluator` against the scene's gt/
    model. The rotation error is the evaluator's `rot_err_median_deg`: the
    median over all pairs of registered images of the angle of
    R_rel_est * R_rel_gt^T, the relative-rotation error, which needs no
    alignment of the model to the ground truth (pairs with an unregistered
    image count in the AUC as failures, not in this median).
Scene generation (its time and peak memory, measured the same way) and the
evaluation are recorded separately and are not part of the mapper's figures.

Then, per layout, the slope of every stage's time and peak memory, of the
total time and of the whole-process peak memory against the number of images
on the log-log plot: the least-squares line through (log n, log value) over
the sizes whose run succeeded (medians over the seeds). Slopes above 1.2
(issue 14: "no stage's time or memory grows faster than about n^1.2") are
flagged.

Writes to --output_dir: results.json (after every run, so an interrupted
benchmark keeps what it measured), results.md (provenance, then per layout a
time table and a memory table, then the slopes), time_vs_images.png and
memory_vs_images.png (gnuplot, log-log, one panel per layout, one line per
stage, the total / whole process in black and a grey n^1.2 reference line;
skipped with a message without gnuplot). With --readme, also replaces the
README's scale section (<!-- scale-benchmark:begin --> ...
<!-- scale-benchmark:end -->; created before the benchmark section if
missing) and copies both plots to docs/benchmark/ beside it.

Scenes are cached under <output_dir>/scenes/ with a stamp (the generator's
options and the sha256 of make_synthetic_scene, as scripts/benchmark.py does)
and generated anew when either changes. Every mapper run starts in a fresh
folder under <output_dir>/runs/. A run that times out (--timeout_s) or whose
process dies is recorded as such and the benchmark goes on; Ctrl-C stops the
run in progress (recorded as interrupted), writes the reports of what was
measured and exits. --resume keeps the successful, evaluated runs of an
earlier results.json in --output_dir that ran the same mapper command with
the same colmap binary (by sha256), and runs the rest; such runs of sizes,
layouts or seeds that this invocation does not ask for stay in results.json
and the reports (run the sizes one invocation at a time and keep them all).

The issue's figures (hours on a small machine; run it alone on it):
    nice -n 10 python3 scripts/benchmark_scale.py --readme README.md

This script parses the options; the benchmark is the package
scripts/glomap_bench/ (scale and the modules it calls, which it shares
with scripts/benchmark.py). --self_test runs the package's tests (no colmap
needed), like ctest does.

Only the Python standard library is used; gnuplot draws the plots.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from glomap_bench import DEFAULT_COLMAP, cli, run  # noqa: E402
from glomap_bench import scale, scale_runs  # noqa: E402


def build_parser():
    """The options of the scale benchmark."""
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=cli.int_list,
                        default=scale.DEFAULT_SIZES, metavar="N,N,...",
                        help="numbers of images (default: %s)" % ",".join(
                            str(n) for n in scale.DEFAULT_SIZES))
    parser.add_argument("--layouts", type=scale_runs.parse_layouts,
                        default=scale_runs.DEFAULT_LAYOUTS,
                        metavar="L,L,...",
                        help="generator layouts: grid (survey), forward "
                        "(street), ring (default: %(default)s)")
    parser.add_argument("--seeds", type=cli.int_list, default=[0],
                        metavar="S,S,...", help="one scene and one run per "
                        "seed (the generator's --random_seed and "
                        "--GlobalMapper.random_seed); the tables show "
                        "medians over the seeds (default: 0)")
    parser.add_argument("--colmap", default=DEFAULT_COLMAP,
                        help="our colmap binary; make_synthetic_scene is "
                        "taken from the same folder (default: %(default)s)")
    parser.add_argument("--reference_colmap", metavar="PATH",
                        help="also run this COLMAP's global_mapper (e.g. "
                        "upstream COLMAP 4.x: ../shared/reference/"
                        "colmap-4.1.1/colmap) on a copy of every scene's "
                        "database, same seed and threads, right after ours, "
                        "and compare both (time, peak memory, accuracy)")
    parser.add_argument("--output_dir", default=scale.DEFAULT_OUTPUT,
                        help="runs, reports and plots; scenes are cached in "
                        "its scenes/ (default: %(default)s)")
    parser.add_argument("--num_threads", type=int, default=-1,
                        help="threads of the generator and of the mapper "
                        "(--GlobalMapper.num_threads; -1: all cores; "
                        "default: %(default)s)")
    parser.add_argument("--timeout_s", type=int,
                        default=scale.DEFAULT_TIMEOUT_S,
                        help="seconds before a generator or mapper run is "
                        "stopped and recorded as timed out; 0: never "
                        "(default: %(default)s)")
    parser.add_argument("--sample_interval_s", type=float,
                        default=run.DEFAULT_SAMPLE_INTERVAL_S,
                        help="interval of the memory samples (default: "
                        "%(default)s)")
    parser.add_argument("--mapper_args", "--extra", default="",
                        metavar="'ARGS'", help="more options of the mapper, "
                        "one shell-quoted string, e.g. "
                        "--mapper_args='--GlobalMapper.skip_retriangulation "
                        "1'")
    parser.add_argument("--resume", action="store_true",
                        help="keep the successful runs of <output_dir>/"
                        "results.json that ran the same mapper command with "
                        "the same colmap binary; run the others")
    parser.add_argument("--readme", metavar="README.md",
                        help="also put the report and the plots into this "
                        "README's scale section")
    parser.add_argument("--self_test", action="store_true",
                        help="check the script's logic on made-up input, "
                        "then exit")
    return parser


def main():
    cli.main(build_parser(), scale.run_scale)


if __name__ == "__main__":
    main()
