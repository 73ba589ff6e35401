"""The runs of scripts/benchmark_scale.py: a synthetic scene per layout,
size and seed (generated, or cached with a stamp), and one measured run of
our global mapper on it, analysed and evaluated against the scene's
ground truth."""

import argparse
import os
import shlex
import shutil
import time

from glomap_bench import models, parse, run, scenes, tables

# Generator layouts and the names the reports use for them.
LAYOUT_LABELS = {"grid": "survey", "forward": "street", "ring": "ring"}
DEFAULT_LAYOUTS = ["grid", "forward"]
# make_synthetic_scene's options of every scene, besides --layout,
# --num_images, --random_seed (and --num_threads, which only its "colmap"
# verification uses and which is therefore not part of the scene's stamp).
GENERATOR_OPTIONS = ["--verification", "ground_truth",
                     "--wrong_match_ratio", "0.3",
                     "--prior_focal_length", "0",
                     "--pixel_noise_px", "1"]


def parse_layouts(text):
    """Argument type: distinct layouts of LAYOUT_LABELS, comma-separated."""
    layouts = [s.strip() for s in text.split(",") if s.strip()]
    unknown = [x for x in layouts if x not in LAYOUT_LABELS]
    if not layouts or unknown or len(set(layouts)) != len(layouts):
        raise argparse.ArgumentTypeError(
            "need distinct layouts among %s: %r" % (
                ", ".join(sorted(LAYOUT_LABELS)), text))
    return layouts


def generator_options(layout, num_images, seed):
    """make_synthetic_scene's options of a scene (its stamp), without
    --output_path and --num_threads."""
    return (["--layout", layout, "--num_images", str(num_images)] +
            GENERATOR_OPTIONS + ["--random_seed", str(seed)])


def run_name(layout, num_images, seed):
    """The folder name of a scene and of its run ("grid_1000_seed0")."""
    return "%s_%d_seed%d" % (layout, num_images, seed)


def use_cached(record, stamp):
    """Marks the record's scene as cached, with the generation figures of
    its stamp (None: none)."""
    record.update((stamp or {}).get("generation") or {})
    record.update(status="ok", cached=True)


def generate_scene(args, record, tool, stamp):
    """Runs the generator into record["path"] (made anew), measured; fills
    the record and writes the stamp if it succeeded."""
    path = record["path"]
    if os.path.isdir(path):
        shutil.rmtree(path)
    os.makedirs(path)
    command = ([tool, "--output_path", path] + record["options"] +
               ["--num_threads", str(args.num_threads)])
    run.log("  scene: $ " + shlex.join(command))
    log_path = os.path.join(path, "generator_log.txt")
    measured = run.measure_process(command, log_path, args.timeout_s,
                                   args.sample_interval_s)
    status = run.process_status(measured, args.timeout_s)
    generation = {"wall_s": round(measured["wall_s"], 3),
                  "peak_rss_mb": round(measured["peak_rss_mb"], 1)
                  if measured["peak_rss_mb"] is not None else None}
    generation.update(parse.parse_generator_summary(log_path))
    record.update(generation)
    record.update(status=status, cached=False, log=log_path)
    if status == "ok" and not os.path.isfile(os.path.join(path,
                                                          "database.db")):
        record["status"] = "failed: no database.db"
    if record["status"] != "ok":
        record["error"] = run.last_lines(log_path)
        run.log("  scene: %s: %s" % (record["status"], " | ".join(
            record["error"])))
        return
    stamp["generation"] = generation
    scenes.write_stamp(os.path.join(path, scenes.SCENE_STAMP), stamp)
    run.log("  scene: generated in %.1f s, peak %s MB%s" % (
        measured["wall_s"], tables.fmt(generation["peak_rss_mb"], 0),
        ", %d verified pairs" % generation["verified_pairs"]
        if "verified_pairs" in generation else ""))


def make_scene(args, layout, num_images, seed):
    """The scene's folder under <output_dir>/scenes/, generated unless a
    cached one has a matching stamp, and its record {"path", "status",
    "cached", "wall_s", "peak_rss_mb", "verified_pairs", ...}."""
    tool = scenes.generator_path(args.colmap)
    path = os.path.join(args.output_dir, "scenes",
                        run_name(layout, num_images, seed))
    stamp_path = os.path.join(path, scenes.SCENE_STAMP)
    options = generator_options(layout, num_images, seed)
    record = {"path": path, "options": options}
    cached = os.path.isfile(os.path.join(path, "database.db"))
    if not os.path.exists(tool):
        if cached:
            run.log("  scene: %s not found, using the cached %s unchecked" % (
                tool, path))
            use_cached(record, scenes.read_stamp(stamp_path))
            return record
        record["status"] = "failed: %s not found" % tool
        return record
    stamp = scenes.scene_stamp(tool, options)
    if cached:
        old = scenes.read_stamp(stamp_path)
        if scenes.stamp_matches(old, stamp):
            use_cached(record, old)
            run.log("  scene: cached %s (stamp matches; generated in %s s, "
                    "%s MB)" % (path, tables.fmt(record.get("wall_s")),
                                tables.fmt(record.get("peak_rss_mb"), 0)))
            return record
        run.log("  scene: %s is stale (%s), generated anew" % (
            path, scenes.stale_reason(old, options)))
    generate_scene(args, record, tool, stamp)
    return record


def mapper_command(args, database, image_path, output_path, seed):
    """The global mapper's command of one run."""
    return ([args.colmap, "global_mapper", "--database_path", database,
             "--image_path", image_path, "--output_path", output_path,
             "--GlobalMapper.random_seed", str(seed),
             "--GlobalMapper.num_threads", str(args.num_threads)] +
            args.mapper_args)


def reference_command(args, database, image_path, output_path, seed):
    """The reference COLMAP's global_mapper command of one run: the same
    seed and threads as ours (upstream COLMAP 4.x has both options), none
    of our --mapper_args."""
    return ([args.reference_colmap, "global_mapper", "--database_path",
             database, "--image_path", image_path, "--output_path",
             output_path, "--GlobalMapper.random_seed", str(seed),
             "--GlobalMapper.num_threads", str(args.num_threads)])


def command_key(command):
    """What makes two mapper runs the same run: the command without the
    binary and the paths (which differ per output folder)."""
    key, skip = [], False
    for word in command[1:]:
        if skip:
            skip = False
            continue
        if word in ("--database_path", "--image_path", "--output_path"):
            skip = True
            continue
        key.append(word)
    return key


def add_evaluation(args, record, scene, output_path):
    """Puts the run's model, its analysis and its evaluation against the
    scene's gt/ into the record (or the status "failed: no model")."""
    model_path, analysis = models.pick_model(args.colmap, output_path)
    if model_path is None and record.get("mapper") == "reference":
        # A model our COLMAP 3.8 cannot analyze: the reference's own
        # model_analyzer (the evaluation still uses ours).
        model_path, analysis = models.pick_model(args.reference_colmap,
                                                 output_path)
    if model_path is None:
        record["status"] = "failed: no model"
        record["error"] = run.last_lines(record["log"])
        return
    record["model_path"] = model_path
    record.update(analysis)
    start = time.monotonic()
    metrics, error = models.evaluate_model(
        args.colmap, model_path, os.path.join(scene["path"], "gt"),
        os.path.join(record["work"], "evaluation.json"), None)
    record["evaluation_s"] = round(time.monotonic() - start, 3)
    if metrics is not None:
        record["evaluation"] = metrics
    else:
        record["evaluation_error"] = error


def fresh_run_folder(work):
    """Makes `work` anew with an empty image folder and an output folder;
    (image path, output path, log path)."""
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)
    image_path = os.path.join(work, "no_images")
    os.makedirs(image_path)
    output_path = os.path.join(work, "sparse")
    os.makedirs(output_path)
    return image_path, output_path, os.path.join(work, "log.txt")


def process_figures(measured):
    """A run record's figures of the mapper process (run.measure_process)."""
    return {"wall_time_s": round(measured["wall_s"], 3),
            "peak_rss_mb": round(measured["peak_rss_mb"], 1)
            if measured["peak_rss_mb"] is not None else None,
            "exit_code": measured["exit_code"], "signal": measured["signal"]}


def run_mapper(args, scene, layout, num_images, seed):
    """One mapper run on a scene, from a fresh folder; its record."""
    work = os.path.join(args.output_dir, "runs",
                        run_name(layout, num_images, seed))
    image_path, output_path, log_path = fresh_run_folder(work)
    # The mapper opens the database read-only (immutable): the scene's own
    # file is used, no copy (a 10,000-image database is large).
    database = os.path.join(scene["path"], "database.db")
    command = mapper_command(args, database, image_path, output_path, seed)
    record = {"layout": layout, "label": LAYOUT_LABELS.get(layout, layout),
              "images": num_images, "seed": seed, "work": work,
              "command": command, "command_key": command_key(command),
              "colmap_sha256": args.colmap_sha256, "scene": scene,
              "log": log_path}
    before = os.stat(database)
    run.log("  mapper: $ " + shlex.join(command))
    measured = run.measure_process(command, log_path, args.timeout_s,
                                   args.sample_interval_s)
    record["status"] = run.process_status(measured, args.timeout_s)
    record.update(process_figures(measured))
    record.update(
        stages=parse.parse_stages(log_path),
        stage_peak_rss_mb={k: round(v, 1) for k, v in
                           measured["stage_peak_rss_mb"].items()},
        stage_rss_samples=measured["stage_rss_samples"])
    record.update(parse.parse_finish(log_path))
    if record["status"] != "ok":
        record["unfinished_stage"] = parse.unfinished_stage(log_path)
    after = os.stat(database)
    if (before.st_size, before.st_mtime) != (after.st_size, after.st_mtime):
        run.log("  warning: the mapper changed %s" % database)
        record["database_changed"] = True
    if record["status"] != "ok":
        record["error"] = run.last_lines(log_path)
        return record
    add_evaluation(args, record, scene, output_path)
    return record


def run_reference(args, scene, layout, num_images, seed):
    """One run of the reference COLMAP's global_mapper on a copy of the
    scene's database (upstream COLMAP migrates a database in place), from a
    fresh folder; its record (mapper "reference": wall time, peak memory
    and evaluation, no stages)."""
    work = os.path.join(args.output_dir, "runs",
                        run_name(layout, num_images, seed) + "_reference")
    image_path, output_path, log_path = fresh_run_folder(work)
    database = os.path.join(work, "database.db")
    shutil.copyfile(os.path.join(scene["path"], "database.db"), database)
    command = reference_command(args, database, image_path, output_path,
                                seed)
    record = {"mapper": "reference", "layout": layout,
              "label": LAYOUT_LABELS.get(layout, layout),
              "images": num_images, "seed": seed, "work": work,
              "command": command, "command_key": command_key(command),
              "colmap_sha256": args.reference_colmap_sha256, "scene": scene,
              "log": log_path}
    run.log("  reference: $ " + shlex.join(command))
    measured = run.measure_process(command, log_path, args.timeout_s,
                                   args.sample_interval_s)
    record["status"] = run.process_status(measured, args.timeout_s)
    record.update(process_figures(measured))
    if record["status"] != "ok":
        record["error"] = run.last_lines(log_path)
        return record
    add_evaluation(args, record, scene, output_path)
    return record


def run_summary_lines(record):
    """What is printed after a run."""
    ev = record.get("evaluation") or {}
    head = "  %s, %s s, peak %s MB" % (
        record["status"], tables.fmt(record.get("wall_time_s"), 2),
        tables.fmt(record.get("peak_rss_mb"), 0))
    if ev:
        head += ", %d/%d registered, AUC@1/3/5 %s/%s/%s, median rotation " \
                "error %s deg" % (ev["registered"], ev["images"],
                                  tables.fmt(ev.get("auc@1")),
                                  tables.fmt(ev.get("auc@3")),
                                  tables.fmt(ev.get("auc@5")),
                                  tables.fmt_deg(
                                      ev.get("rot_err_median_deg")))
    elif record.get("evaluation_error"):
        head += ", evaluation failed: %s" % " ".join(
            record["evaluation_error"])
    lines = [head]
    memory = record.get("stage_peak_rss_mb") or {}
    stages = ["%s %.2f s/%s MB" % (name, seconds,
                                   tables.fmt(memory.get(name), 0))
              for name, seconds in parse.merged_stages(record)]
    if stages:
        lines.append("  stages: " + ", ".join(stages))
    if record.get("error"):
        lines.append("  last lines: " + " | ".join(
            line if len(line) <= 200 else line[:197] + "..."
            for line in record["error"]))
    return lines
