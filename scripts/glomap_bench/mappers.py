"""The mappers of scripts/benchmark.py (ours, COLMAP 3.8's stock `mapper`
and another build's `global_mapper`), the order of their runs, and one run:
its own folder and database copy, wall time and peak memory, model
analysis and evaluation."""

import os
import shutil
import sys

from glomap_bench import datasets, models, parse, run

# The colmap command of each mapper.
MAPPERS = {
    "global": "global_mapper",
    "incremental": "mapper",
    "reference": "global_mapper",
}
# Order of the mappers within one repeat, and their labels.
MAPPER_ORDER = ["global", "incremental", "reference"]
MAPPER_LABELS = {
    "global": "ours `global_mapper`",
    "incremental": "COLMAP 3.8 `mapper`",
    "reference": "reference `global_mapper`",
}
# Runs per mapper and input without --repeats.
DEFAULT_REPEATS = 3
DEFAULT_SYNTHETIC_REPEATS = 1


def run_schedule(mappers, seeds, repeats):
    """The runs on one input, [(mapper, seed, repeat)]: repeat by repeat,
    the mappers in MAPPER_ORDER (ours once per seed), so that the mappers
    alternate instead of all runs of ours coming first."""
    schedule = []
    for repeat in range(repeats):
        for mapper in MAPPER_ORDER:
            if mapper not in mappers:
                continue
            if mapper == "global":
                schedule += [(mapper, seed, repeat) for seed in seeds]
            else:
                schedule.append((mapper, None, repeat))
    return schedule


def run_dir_name(mapper, seed, repeat=0):
    """The folder name of one run ("global_seed2_run2")."""
    name = "global_seed%d" % seed if mapper == "global" else mapper
    return name + "_run%d" % (repeat + 1)


def check_reference(binary):
    """Exits with a message unless `binary` is a colmap with global_mapper."""
    if not os.access(binary, os.X_OK) or os.path.isdir(binary):
        sys.exit("error: --reference_colmap %s is not an executable" % binary)
    try:
        code, text = run.capture([binary, "global_mapper", "-h"])
    except OSError as error:
        sys.exit("error: --reference_colmap %s cannot run: %s" % (binary,
                                                                 error))
    if "not recognized" in text or "--database_path" not in text:
        sys.exit("error: --reference_colmap %s has no `global_mapper` "
                 "command (`%s global_mapper -h` exited with %d: %s); it "
                 "needs a COLMAP build with the global mapper, e.g. upstream "
                 "COLMAP 4.x" % (binary, binary, code, (text.strip()
                                                        .splitlines()
                                                        or ["no output"])[-1]))


def prepare_run_folder(work, dataset):
    """Makes the fresh folder `work` with a copy of the dataset's database;
    returns (database, image path, output path, log path)."""
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)
    database = os.path.join(work, "database.db")
    shutil.copyfile(os.path.join(dataset, "database.db"), database)
    image_path = os.path.join(dataset, "images")
    if not os.path.isdir(image_path):
        # The mappers need an existing folder; without images the models just
        # have no colours.
        image_path = os.path.join(work, "no_images")
        os.makedirs(image_path)
    output_path = os.path.join(work, "sparse")
    os.makedirs(output_path)
    return database, image_path, output_path, os.path.join(work, "log.txt")


def run_title(mapper, seed, repeat, repeats):
    """"global_mapper (seed 0, run 1/3)", "reference global_mapper", ..."""
    details = [] if seed is None else ["seed %d" % seed]
    if repeats > 1:
        details.append("run %d/%d" % (repeat + 1, repeats))
    return ("reference " if mapper == "reference" else "") + MAPPERS[mapper] + (
        " (%s)" % ", ".join(details) if details else "")


def add_model_figures(args, record, binary, dataset, work, output_path):
    """Puts the model of a successful run, its analysis and its evaluation
    into the record (or the status "failed: no model"); returns the
    analysis (None without a model)."""
    model_path, analysis = models.pick_model(args.colmap, output_path)
    if model_path is None and binary != args.colmap:
        # A model our COLMAP 3.8 cannot analyze: the reference's own
        # model_analyzer (the evaluation still uses ours).
        model_path, analysis = models.pick_model(binary, output_path)
    if model_path is None:
        record["status"] = "failed: no model"
        return None
    record["model_path"] = model_path
    record.update(analysis)
    gt_path = os.path.join(dataset, "gt")
    if models.is_model_dir(gt_path):
        metrics, error = models.evaluate_model(
            args.colmap, model_path, gt_path,
            os.path.join(work, "evaluation.json"),
            args.position_thresholds, args.pose_thresholds)
        if metrics is not None:
            record["evaluation"] = metrics
        else:
            record["evaluation_error"] = error
    return analysis


def run_summary(record, wall_s, peak_mb, analysis):
    """The line printed after a run: status, wall time (s), peak memory
    (MB; None: unknown), figures."""
    summary = "%s, %.1f s" % (record["status"], wall_s)
    if peak_mb is not None:
        summary += ", %.0f MB" % peak_mb
    evaluation = record.get("evaluation")
    if evaluation:
        summary += ", %d/%d registered, AUC@3 %.1f" % (
            evaluation["registered"], evaluation["images"],
            evaluation.get("auc@3") or 0.0)
        if evaluation.get("cameras_beyond") is not None:
            summary += ", %d camera(s) beyond %g%% of the scene" % (
                evaluation["cameras_beyond"], 100 * evaluation.get(
                    "cameras_beyond_fraction", models.BEYOND_FRACTION))
    elif analysis:
        summary += ", %d registered" % analysis["registered"]
    if record.get("replaced_images") is not None:
        summary += ", re-placed %d, left out %d" % (
            record["replaced_images"], record["left_out_images"])
    return summary


def run_one(args, dataset, mapper, seed, index, total, repeat=0, repeats=1):
    """One run; seed: --GlobalMapper.random_seed of ours (None for the
    others); repeat: 0-based, of repeats. Every run starts from a fresh
    folder with its own copy of the database (the original is never opened
    by a mapper: a newer COLMAP may migrate its schema). Returns its
    record; Ctrl-C stops the benchmark (KeyboardInterrupt)."""
    name = os.path.basename(dataset)
    command_name = MAPPERS[mapper]
    binary = args.reference_colmap if mapper == "reference" else args.colmap
    work = os.path.join(args.output_dir, "runs", name,
                        run_dir_name(mapper, seed, repeat))
    database, image_path, output_path, log_path = prepare_run_folder(
        work, dataset)

    record = {"dataset": name, "mapper": mapper, "command": command_name,
              "binary": binary, "status": "ok", "repeat": repeat,
              "camera_setup": datasets.camera_setup_label(
                  args.camera_setup, args.camera_model, args.exif_error)}
    if seed is not None:
        record["seed"] = seed
    record["db_images"] = models.count_db_images(database)
    title = run_title(mapper, seed, repeat, repeats)
    run.log("[%d/%d] %s: %s ..." % (index, total, name, title))
    command = [binary, command_name, "--database_path", database,
               "--image_path", image_path, "--output_path", output_path]
    if seed is not None:
        command += ["--GlobalMapper.random_seed", str(seed)]
    measured = run.measure_process(command, log_path, args.timeout)
    if measured["interrupted"]:
        raise KeyboardInterrupt
    code = run.shell_exit_code(measured)
    peak_mb = measured["peak_rss_mb"]
    record.update({"wall_time_s": round(measured["wall_s"], 3),
                   "peak_rss_mb": round(peak_mb, 1)
                   if peak_mb is not None else None,
                   "exit_code": code, "log": log_path})
    if mapper == "global":
        record["stages"] = parse.parse_stages(log_path)
        record.update(parse.parse_finish(log_path))

    analysis = None
    if measured["timed_out"]:
        record["status"] = "failed: timeout after %d s" % args.timeout
    elif code != 0:
        # COLMAP 3.8's mapper exits with an error when it finds no model.
        no_model = models.pick_model(args.colmap, output_path)[0] is None
        record["status"] = "failed: %sexit %d" % (
            "no model, " if no_model else "", code)
        record["error"] = run.last_lines(log_path)
    else:
        analysis = add_model_figures(args, record, binary, dataset, work,
                                     output_path)
    summary = run_summary(record, measured["wall_s"], peak_mb, analysis)
    run.log("[%d/%d] %s: %s %s" % (index, total, name, title, summary))
    return record
