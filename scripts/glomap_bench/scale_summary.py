"""The runs of scripts/benchmark_scale.py combined: one row per layout and
size (medians over the seeds), and per layout the log-log slope of every
stage's time and peak memory against the number of images."""

from glomap_bench import parse, stats

# Pose AUC thresholds reported, in degrees (model_evaluator's default set
# 1,3,5,10 contains them).
AUC_THRESHOLDS = ["1", "3", "5"]
# Issue 14: no stage's time or memory grows faster than about n^SLOPE_BAR.
SLOPE_BAR = 1.2


def other_time(record):
    """Wall time outside the stages (start-up, writing the models)."""
    if record.get("wall_time_s") is None or not record.get("stages"):
        return None
    return max(0.0, record["wall_time_s"] - sum(parse.stage_times(record)
                                                .values()))


def status_text(record):
    """A run's status, with the stage it stopped in when it did not
    finish."""
    text = record["status"]
    if record.get("unfinished_stage"):
        text += " in %s" % record["unfinished_stage"]
    return text


def summary_stage_names(pool):
    """The stages of the runs, a stage a run stopped in included (it has
    memory samples, no time)."""
    names = parse.stage_order(pool)
    for r in pool:
        if r.get("unfinished_stage") and r["unfinished_stage"] not in names:
            names.append(r["unfinished_stage"])
    return names


def add_accuracy(row, ok):
    """Puts the medians of the successful runs' evaluations into the row:
    registered, the ground truth's images, AUCs, median rotation error."""
    evaluations = [r["evaluation"] for r in ok if r.get("evaluation")]
    row["registered"] = stats.median(e.get("registered")
                                     for e in evaluations)
    row["gt_images"] = evaluations[0]["images"] if evaluations else None
    if row["registered"] is None:
        row["registered"] = stats.median(r.get("registered") for r in ok)
    for t in AUC_THRESHOLDS:
        row["auc@" + t] = stats.median(e.get("auc@" + t)
                                       for e in evaluations)
    row["rot_err_median_deg"] = stats.median(
        e.get("rot_err_median_deg") for e in evaluations)


def summarize(records, layout, num_images):
    """One row per layout and size: the medians over the successful runs
    (seeds) of every figure; the status of the first run if none
    succeeded. None if there is no run."""
    runs = [r for r in records
            if r["layout"] == layout and r["images"] == num_images]
    if not runs:
        return None
    ok = [r for r in runs if r["status"] == "ok"]
    row = {"layout": layout, "images": num_images, "runs": len(runs),
           "ok_runs": len(ok), "status": "ok" if ok else runs[0]["status"],
           "failed": ["seed %d: %s" % (r["seed"], status_text(r))
                      for r in runs if r["status"] != "ok"]}
    if not ok:
        row["status_text"] = status_text(runs[0])
    # Without a successful run, what the failed ones measured (stages they
    # finished, time and memory until they stopped); never in the slopes and
    # plots, which take the successful rows only.
    pool = ok or runs
    names = summary_stage_names(pool)
    row["stage_names"] = names
    row["time"] = {name: stats.median(parse.stage_times(r).get(name)
                                      for r in pool) for name in names}
    row["time"][parse.OTHER] = stats.median(other_time(r) for r in ok)
    row["memory"] = {name: stats.median(
        (r.get("stage_peak_rss_mb") or {}).get(name) for r in pool)
        for name in names + [parse.OTHER]}
    row["total_s"] = stats.median(r.get("wall_time_s") for r in pool)
    row["peak_rss_mb"] = stats.median(r.get("peak_rss_mb") for r in pool)
    add_accuracy(row, ok)
    scenes = [r.get("scene") or {} for r in runs]
    row["generation_s"] = stats.median(s.get("wall_s") for s in scenes)
    row["generation_peak_rss_mb"] = stats.median(
        s.get("peak_rss_mb") for s in scenes)
    row["evaluation_s"] = stats.median(r.get("evaluation_s") for r in ok)
    return row


def layout_order(records, layouts=None):
    """The layouts of the records: those of `layouts` first, in order."""
    order = list(layouts or [])
    for r in records:
        if r["layout"] not in order:
            order.append(r["layout"])
    return [layout for layout in order
            if any(r["layout"] == layout for r in records)]


def layout_rows(records, layout):
    """summarize() of every size of a layout, by size."""
    sizes = sorted({r["images"] for r in records if r["layout"] == layout})
    return [summarize(records, layout, n) for n in sizes]


def ok_rows_and_stage_names(rows):
    """The successful rows, and the names of their stages in the order they
    first appear."""
    ok = [r for r in rows if r and r["status"] == "ok"]
    names = []
    for r in ok:
        for name in r["stage_names"]:
            if name not in names:
                names.append(name)
    return ok, names


def slope_entry(name, ok, largest):
    """The slopes of one stage (or OTHER, or "total") over the successful
    rows, and its figures at the largest size."""
    if name == "total":
        times = [(r["images"], r["total_s"]) for r in ok]
        memory = [(r["images"], r["peak_rss_mb"]) for r in ok]
    else:
        times = [(r["images"], r["time"].get(name)) for r in ok]
        memory = [(r["images"], r["memory"].get(name)) for r in ok]
    entry = {"name": name, "time_slope": stats.fit_slope(times),
             "memory_slope": stats.fit_slope(memory),
             "points": len([1 for _, v in times if v is not None and v > 0])}
    if largest:
        entry["images_at_max"] = largest["images"]
        entry["time_at_max"] = (largest["total_s"] if name == "total"
                                else largest["time"].get(name))
        entry["memory_at_max"] = (
            largest["peak_rss_mb"] if name == "total"
            else largest["memory"].get(name))
        if entry["time_at_max"] is not None and largest["total_s"]:
            entry["share_at_max"] = (entry["time_at_max"] /
                                     largest["total_s"])
    entry["flags"] = [what for what, slope in
                      (("time", entry["time_slope"]),
                       ("memory", entry["memory_slope"]))
                      if slope is not None and slope > SLOPE_BAR]
    return entry


def slopes(rows):
    """Per stage (then OTHER, then "total"), the time and memory slopes over
    the successful rows: [{"name", "time_slope", "memory_slope", "points",
    "time_at_max", "memory_at_max", "share_at_max", "flags"}]."""
    ok, names = ok_rows_and_stage_names(rows)
    largest = max(ok, key=lambda r: r["images"]) if ok else None
    return [slope_entry(name, ok, largest)
            for name in names + [parse.OTHER, "total"]]


def all_slopes(records, layouts):
    """{layout: slopes()} of every layout."""
    return {layout: slopes(layout_rows(records, layout))
            for layout in layout_order(records, layouts)}
