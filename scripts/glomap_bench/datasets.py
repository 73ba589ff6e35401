"""The inputs of scripts/benchmark.py: dataset folders (a database.db,
optionally images/ and gt/), their copies with rewritten cameras
(--camera_setup), and cached synthetic scenes (--synthetic)."""

import os
import shlex
import shutil
import sys

from glomap_bench import REPO_DIR, run, scenes

DEFAULT_DATASETS = os.path.join(os.path.dirname(REPO_DIR), "shared",
                                "datasets")
CAMERA_SETUPS = ("database", "shared", "per_image", "per_image_exif")


def find_datasets(paths):
    """The dataset folders among paths, a folder of datasets standing for
    its datasets (in name order)."""
    datasets = []
    for path in paths:
        path = os.path.abspath(path)
        if os.path.isfile(os.path.join(path, "database.db")):
            datasets.append(path)
        elif os.path.isdir(path):
            # A folder of datasets.
            for name in sorted(os.listdir(path)):
                sub = os.path.join(path, name)
                if os.path.isfile(os.path.join(sub, "database.db")):
                    datasets.append(sub)
    return datasets


def camera_setup_label(setup, model, exif_error):
    """The main table's "cameras" cell of a setup."""
    if setup == "database":
        return "as in the database"
    where = "shared" if setup == "shared" else "per image"
    prior = ("EXIF %g%% off" % (100 * exif_error) if setup == "per_image_exif"
             else "no prior")
    return "%s %s, %s" % (where, model, prior)


def rewrite_cameras_command(args, dataset, output_path):
    """scripts/rewrite_cameras.py's command that writes `dataset`'s
    database rewritten to --camera_setup to output_path."""
    command = [sys.executable,
               os.path.join(REPO_DIR, "scripts", "rewrite_cameras.py"),
               "--database_path", os.path.join(dataset, "database.db"),
               "--output_path", output_path,
               "--camera_mode",
               "shared" if args.camera_setup == "shared" else "per_image",
               "--camera_model", args.camera_model]
    if args.camera_setup == "per_image_exif":
        command += ["--focal", "exif", "--gt_path",
                    os.path.join(dataset, "gt"),
                    "--exif_error", str(args.exif_error)]
    return command


def camera_setup_dataset(args, dataset):
    """A dataset folder whose database.db is `dataset`'s rewritten to
    --camera_setup (scripts/rewrite_cameras.py; the input is only copied),
    with gt/ and images/ linked; `dataset` itself for "database"."""
    if args.camera_setup == "database":
        return dataset
    name = os.path.basename(dataset)
    slug = "%s_%s" % (args.camera_setup, args.camera_model)
    target = os.path.join(args.output_dir, "camera_setups", slug, name)
    if os.path.isdir(target):
        shutil.rmtree(target)
    os.makedirs(target)
    code, text = run.capture(rewrite_cameras_command(
        args, dataset, os.path.join(target, "database.db")))
    if code != 0:
        sys.exit("error: rewriting the cameras of %s failed:\n%s" % (
            dataset, text))
    for sub in ("gt", "images"):
        if os.path.isdir(os.path.join(dataset, sub)):
            os.symlink(os.path.join(dataset, sub), os.path.join(target, sub))
    return target


def synthetic_options(num_images):
    """make_synthetic_scene's options (but --output_path) for a scene of
    num_images images."""
    options = ["--num_images", str(num_images)]
    if num_images > 300:
        # Large scenes: an aerial survey with ground-truth verification (the
        # generator's COLMAP verification would dominate the run).
        options += ["--layout", "grid", "--verification", "ground_truth",
                    "--wrong_match_ratio", "0.3", "--prior_focal_length", "0"]
    return options


def make_synthetic(args, num_images):
    """The folder of a synthetic scene under <output_dir>/scenes/, generated
    unless a cached one has a matching stamp; None if it cannot be made."""
    tool = scenes.generator_path(args.colmap)
    path = os.path.join(args.output_dir, "scenes", "synthetic_%d" % num_images)
    stamp_path = os.path.join(path, scenes.SCENE_STAMP)
    cached = os.path.isfile(os.path.join(path, "database.db"))
    options = synthetic_options(num_images)
    if not os.path.exists(tool):
        if cached:
            run.log("synthetic scene: %s not found, using the cached %s "
                    "unchecked" % (tool, path))
            return path
        run.log("synthetic scene: %s not found, skipped" % tool)
        return None
    stamp = scenes.scene_stamp(tool, options)
    if cached:
        old = scenes.read_stamp(stamp_path)
        if scenes.stamp_matches(old, stamp):
            run.log("synthetic scene: cached %s (stamp matches)" % path)
            return path
        run.log("synthetic scene: %s is stale (%s), generated anew" % (
            path, scenes.stale_reason(old, options)))
    if os.path.isdir(path):
        shutil.rmtree(path)
    os.makedirs(path)
    command = [tool, "--output_path", path] + options
    run.log("synthetic scene: $ " + shlex.join(command))
    code, text = run.capture(command)
    if code != 0 or not os.path.isfile(os.path.join(path, "database.db")):
        run.log("synthetic scene: %s failed: %s" %
                (tool, (text.strip().splitlines() or ["no output"])[-1]))
        return None
    scenes.write_stamp(stamp_path, stamp)
    return path
