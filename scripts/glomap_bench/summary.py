"""The runs of scripts/benchmark.py combined: per dataset and mapper, the
median over seeds and repeats of every figure, with the runs kept for the
spread."""

from glomap_bench import mappers, parse, stats

# The figures of a run whose median a summary takes.
MEDIAN_KEYS = ("wall_time_s", "registered", "points", "mean_track_length",
               "mean_reproj_error_px", "replaced_images", "left_out_images")


def median_evaluation(evaluations):
    """The median of every number of the evaluations (dicts of
    model_evaluator), by the first one's keys."""
    evaluation = {}
    for key in evaluations[0]:
        values = [e.get(key) for e in evaluations]
        if all(isinstance(v, (int, float)) or v is None for v in values):
            evaluation[key] = stats.median(values)
    return evaluation


def summarize_runs(runs):
    """One record for the runs of one mapper on one dataset (ours: over the
    seeds and repeats): the median of every number over the successful runs
    (wall time included), the maximum of the peak memory, the model of the
    run with the median time, and the runs themselves (for the spread). One
    run: itself."""
    if len(runs) == 1:
        return dict(runs[0], runs=runs)
    ok_runs = [r for r in runs if r["status"] == "ok"]
    pool = ok_runs or runs
    summary = {"dataset": runs[0]["dataset"], "mapper": runs[0]["mapper"],
               "camera_setup": runs[0].get("camera_setup"),
               "command": runs[0].get("command"), "runs": runs,
               "status": "ok" if ok_runs else runs[0]["status"]}
    seeds = {r.get("seed") for r in runs}
    if len(seeds) == 1 and None not in seeds:
        summary["seed"] = runs[0]["seed"]
    for key in MEDIAN_KEYS:
        summary[key] = stats.median(r.get(key) for r in pool)
    peaks = [r["peak_rss_mb"] for r in pool if r.get("peak_rss_mb")
             is not None]
    summary["peak_rss_mb"] = max(peaks) if peaks else None
    middle = stats.median_time_run(pool)
    for key in ("model_path", "image_names", "db_images"):
        if key in middle:
            summary[key] = middle[key]
    evaluations = [r["evaluation"] for r in pool if r.get("evaluation")]
    if evaluations:
        summary["evaluation"] = median_evaluation(evaluations)
    stage_runs = [r for r in pool if r.get("stages")]
    if stage_runs:
        summary["stages"] = [
            [name, stats.median(parse.stage_times(r).get(name)
                                for r in stage_runs)]
            for name in parse.stage_order(stage_runs)]
    return summary


def dataset_order(records):
    """The dataset names of the records, in first appearance."""
    names = []
    for r in records:
        if r["dataset"] not in names:
            names.append(r["dataset"])
    return names


def summary_records(records):
    """Rows of the main table: per dataset, ours (over the seeds and
    repeats), the stock mapper and the reference (over the repeats), in the
    order of the runs."""
    rows = []
    for name in dataset_order(records):
        for mapper in mappers.MAPPER_ORDER:
            runs = [r for r in records
                    if r["dataset"] == name and r["mapper"] == mapper]
            if runs:
                rows.append(summarize_runs(runs))
    return rows


def seed_summaries(records, name):
    """Our runs on dataset `name`, one summary per seed over its repeats
    (summarize_runs: median time and figures), in seed order of the runs."""
    seeds = []
    for r in records:
        if (r["dataset"] == name and r["mapper"] == "global"
                and r.get("seed") not in seeds):
            seeds.append(r.get("seed"))
    return [summarize_runs([r for r in records if r["dataset"] == name and
                            r["mapper"] == "global" and r.get("seed") == s])
            for s in seeds]


def run_label(run):
    """"seed 0 run 2" / "run 2" / "seed 0" of one run."""
    words = []
    if run.get("seed") is not None:
        words.append("seed %d" % run["seed"])
    if run.get("repeat") is not None:
        words.append("run %d" % (run["repeat"] + 1))
    return " ".join(words) or "run"


def runs_note(runs):
    """"(median of 6 runs: 2 seeds × 3 repeats)", "(median of 3 runs)", ...;
    "" for one run."""
    count = len(runs)
    if count < 2:
        return ""
    seeds = len({r.get("seed") for r in runs})
    if seeds > 1 and count > seeds:
        return " (median of %d runs: %d seeds × %d repeats)" % (
            count, seeds, count // seeds)
    if seeds > 1:
        return " (median of %d seeds)" % seeds
    return " (median of %d runs)" % count
