"""The acceptance bars of issue 10, checked on every seed of our global
mapper in scripts/benchmark.py: all images registered; AUC@3 at least the
better of the reference mappers' figures in the dataset's README minus 0.5;
no registered camera beyond 5% of the scene size; KITTI_sequence_1's mean
position error. On stock-relative datasets (dino-363, --stock_relative,
rewritten camera setups) the bars are the stock mapper's figures instead."""

import os

from glomap_bench import models, parse, summary, tables

# AUC@3 at least the better reference mapper's figure minus this.
AUC_BAR_MARGIN = 0.5
# Stock-relative datasets (dino-363): AUC@3 at least the stock mapper's minus
# this, in at most this fraction of its wall time.
STOCK_AUC_MARGIN = 1.0
STOCK_TIME_RATIO = 0.5
# Per-dataset maximum mean position error, in ground-truth units.
MAX_POSITION_ERROR = {"KITTI_sequence_1": 0.02}
# Value of a "not applicable" bar (True: met, False: failed, None: could not
# be checked).
NOT_APPLICABLE = "n/a"
# The bars' names in a row's failed and unchecked lists.
BAR_NAMES = {"registered": "registered", "auc@3": "AUC@3",
             "beyond": "cameras beyond", "position": "position error",
             "time": "time"}


def run_registered(record):
    """(registered, images) of a run; images None if unknown."""
    ev = record.get("evaluation") or {}
    if record["status"] != "ok":
        return 0, ev.get("images") or record.get("db_images")
    if ev:
        return ev["registered"], ev["images"]
    return record.get("registered"), record.get("db_images")


def image_names(colmap, record):
    """The registered images' names of a run (given ones in "image_names"
    first); None if its model cannot be read."""
    if "image_names" in record:  # Given (tests).
        return set(record["image_names"])
    if record["status"] != "ok":
        return set()
    return models.read_image_names(colmap, record.get("model_path"))


def stock_registration_bar(colmap, record, stock, our_text):
    """(cell, verdict): ours registers every image the stock mapper of this
    run registers."""
    registered = run_registered(record)[0]
    stock_names = image_names(colmap, stock)
    our_names = image_names(colmap, record)
    if stock["status"] != "ok":
        return our_text + " (stock: none)", True
    if stock_names is not None and our_names is not None:
        missing = sorted(stock_names - our_names)
        if missing:
            return "%s, misses %d of stock's %d (%s)" % (
                our_text, len(missing), len(stock_names),
                ", ".join(missing[:3]) + (", ..." if len(missing) > 3
                                          else "")), False
        return "%s ⊇ stock's %d" % (our_text, len(stock_names)), True
    # No image names: compare the counts.
    stock_count = run_registered(stock)[0]
    return "%s vs stock %s (counts)" % (our_text, stock_count), (
        None if registered is None or stock_count is None
        else registered >= stock_count)


def registration_bar(colmap, record, stock, stock_ref, stock_relative):
    """(cell, verdict) of the registration bar."""
    registered, images = run_registered(record)
    our_text = "%s/%s" % ("–" if registered is None else "%g" % registered,
                          "?" if images is None else images)
    if stock_relative and stock is not None:
        return stock_registration_bar(colmap, record, stock, our_text)
    if stock_relative and stock_ref.get("registered"):
        needed = stock_ref["registered"][0]
        return "%s vs stock %d (README)" % (our_text, needed), (
            None if registered is None else registered >= needed)
    return our_text, (None if registered is None or images is None
                      else registered >= images)


def auc_bar_value(reference, stock, stock_ref, stock_relative):
    """(the AUC@3 bar or None, where it comes from)."""
    if stock_relative:
        if stock is not None:
            stock_ev = stock.get("evaluation") or {}
            stock_auc = (stock_ev.get("auc@3") if stock["status"] == "ok"
                         else 0.0)
            source = "stock"
        else:
            stock_auc = stock_ref.get("auc@3")
            source = "stock README"
        if stock_auc is None:
            return None, source
        return stock_auc - STOCK_AUC_MARGIN, source
    figures = [row.get("auc@3") for row in (reference or {}).values()]
    figures = [f for f in figures if f is not None]
    if not figures:
        return None, None
    return max(figures) - AUC_BAR_MARGIN, "README"


def auc_bar(record, reference, stock, stock_ref, stock_relative):
    """(cell, verdict) of the AUC@3 bar."""
    ev = record.get("evaluation") or {}
    ours = ev.get("auc@3") if record["status"] == "ok" else 0.0
    bar, source = auc_bar_value(reference, stock, stock_ref, stock_relative)
    if bar is None:
        return tables.fmt(ours), None if stock_relative else NOT_APPLICABLE
    if ours is None:
        return "– (bar %.1f, %s)" % (bar, source), None
    # Compared as shown (one decimal, like the README figures).
    met = round(ours, 1) >= round(bar, 1) - 1e-9
    return "%.1f %s %.1f (%s)" % (ours, "≥" if met else "<", bar,
                                  source), met


def beyond_bar(record):
    """(cell, verdict) of the bar on cameras beyond 5% of the scene size."""
    ev = record.get("evaluation") or {}
    if record["status"] != "ok":
        return "–", NOT_APPLICABLE
    if ev.get("cameras_beyond") is None:
        return ("– (not reported)" if ev else "– (no ground truth)"), None
    fraction = ev.get("cameras_beyond_fraction", models.BEYOND_FRACTION)
    cell = str(ev["cameras_beyond"])
    if fraction is not None and abs(fraction -
                                    models.BEYOND_FRACTION) > 1e-9:
        cell += " (at %g%%)" % (100 * fraction)
    return cell, ev["cameras_beyond"] == 0


def position_bar(record, max_position_error):
    """(cell, verdict) of the mean position error bar (None: none)."""
    ev = record.get("evaluation") or {}
    if max_position_error is None:
        return "–", NOT_APPLICABLE
    if record["status"] != "ok":
        return "– (bar %g)" % max_position_error, False
    if not ev:
        return "– (no ground truth)", None
    error = ev.get("pos_err_mean")
    met = error is not None and error <= max_position_error
    return "%s %s %g" % (tables.fmt_error(error), "≤" if met else ">",
                         max_position_error), met


def time_bar(record, stock, stock_ref, stock_relative):
    """(cell, verdict) of the time against the stock mapper
    (stock-relative datasets)."""
    if not stock_relative:
        return "–", NOT_APPLICABLE
    if stock is not None:
        stock_time, source = stock.get("wall_time_s"), "stock"
    else:
        stock_time, source = stock_ref.get("wall_time_s"), "stock README"
    ours_time = record.get("wall_time_s")
    if not stock_time or ours_time is None:
        return "–", None
    ratio = ours_time / stock_time
    met = ratio <= STOCK_TIME_RATIO
    return "%.1f/%.1f s = %.2f× %s %g× (%s)" % (
        ours_time, stock_time, ratio, "≤" if met else ">",
        STOCK_TIME_RATIO, source), met


def bar_result(record, verdicts):
    """(failed bars, unchecked bars, the result cell) of a row's
    verdicts."""
    failed = [BAR_NAMES[k] for k, v in verdicts.items() if v is False]
    unchecked = [BAR_NAMES[k] for k, v in verdicts.items() if v is None]
    if record["status"] != "ok":
        failed.insert(0, record["status"])
    if failed:
        result = "**FAIL** (%s)" % ", ".join(failed)
    elif unchecked:
        result = "unchecked (%s)" % ", ".join(unchecked)
    else:
        result = "pass"
    return failed, unchecked, result


def check_bars(colmap, record, reference, stock, stock_relative,
               max_position_error=None):
    """The bars of one run of ours. reference: parse_reference() of the
    dataset; stock: the stock mapper's run on it in this benchmark (or None);
    stock_relative: bars relative to the stock mapper (dino-363). Returns a
    row {"dataset", "seed", "cells": {bar: text}, "verdicts": {bar: True /
    False / None (unchecked) / NOT_APPLICABLE}, "result"}."""
    stock_ref = (reference or {}).get("incremental") or {}
    bars = {
        "registered": registration_bar(colmap, record, stock, stock_ref,
                                       stock_relative),
        "auc@3": auc_bar(record, reference, stock, stock_ref,
                         stock_relative),
        "beyond": beyond_bar(record),
        "position": position_bar(record, max_position_error),
        "time": time_bar(record, stock, stock_ref, stock_relative),
    }
    cells = {k: cell for k, (cell, _) in bars.items()}
    verdicts = {k: verdict for k, (_, verdict) in bars.items()}
    if record.get("replaced_images") is not None:
        cells["moved"] = "%g/%g" % (record["replaced_images"],
                                    record["left_out_images"])
    else:
        cells["moved"] = "–"
    failed, unchecked, result = bar_result(record, verdicts)
    return {"dataset": record["dataset"], "seed": record.get("seed"),
            "stock_relative": stock_relative, "cells": cells,
            "verdicts": verdicts, "failed": failed, "unchecked": unchecked,
            "result": result}


def compute_bars(colmap, records, datasets, stock_relative_names=()):
    """The bars per seed of ours and dataset, judged on the median over the
    seed's repeats against the stock mapper's median over its repeats.
    stock_relative_names: datasets (folder names) judged against the stock
    mapper in any case."""
    rows = []
    for dataset in datasets:
        name = os.path.basename(dataset)
        reference = parse.parse_reference(dataset)
        stock_runs = [r for r in records if r["dataset"] == name
                      and r["mapper"] == "incremental"]
        stock = summary.summarize_runs(stock_runs) if stock_runs else None
        # The README has the stock mapper's figures but no upstream
        # global_mapper's (dino-363): compare with the stock mapper.
        stock_relative = name in stock_relative_names or (
            reference is not None and "incremental" in reference
            and "upstream" not in reference)
        for r in summary.seed_summaries(records, name):
            row = check_bars(colmap, r, reference, stock, stock_relative,
                             MAX_POSITION_ERROR.get(name))
            row["runs"] = len(r.get("runs") or [r])
            rows.append(row)
    return rows


def all_bars_met(bars):
    """(met, the final line)."""
    if not bars:
        return False, "all bars met: no (no run of the global mapper)"
    failing = [b for b in bars if b["failed"]]
    unchecked = [b for b in bars if not b["failed"] and b["unchecked"]]
    if not failing and not unchecked:
        return True, "all bars met: yes (%d of %d runs pass)" % (len(bars),
                                                                len(bars))
    notes = []
    if failing:
        notes.append("%d of %d runs fail" % (len(failing), len(bars)))
    if unchecked:
        notes.append("%d run(s) could not be checked" % len(unchecked))
    return False, "all bars met: no (%s)" % "; ".join(notes)


def bars_note():
    """The paragraph under the bars table that states the bars."""
    return (
        "Bars: every image registered; AUC@3° at least the better of the "
        "reference mappers' figures in the dataset's README (COLMAP 3.8 "
        "`mapper`, COLMAP 4.1.1 `global_mapper`) minus %g; no registered "
        "camera beyond %g%% of the scene size; %s. Stock-relative datasets "
        "(README without upstream figures, e.g. dino-363): every image the "
        "stock `mapper` of this run registers, AUC@3° at most %g below it, "
        "in at most %g× its time (its README figures if it was not run). "
        "Without README figures (synthetic scenes) only the registration "
        "and cameras-beyond bars apply. AUC compared at one decimal. Times: "
        "medians over the repeats." % (
            AUC_BAR_MARGIN, 100 * models.BEYOND_FRACTION,
            "; ".join("%s: mean position error at most %g" % item
                      for item in sorted(MAX_POSITION_ERROR.items())),
            STOCK_AUC_MARGIN, STOCK_TIME_RATIO))


def bars_table(bars, beyond):
    """The bars table (beyond: the cameras-beyond column's title), its note
    and the final line."""
    repeated = any(b.get("runs", 1) > 1 for b in bars)
    lines = ["Bars of issue 10, per %s of our `global_mapper`:" % (
        "seed (the median time and figures over its repeats, against the "
        "stock mapper's median)" if repeated else "run"), "",
             "| dataset | seed | registered | AUC@3° vs bar | %s "
             "| mean position error vs bar | time vs stock mapper "
             "| re-placed/left out | result |" % beyond,
             "|---|---|---|---|---|---|---|---|---|"]
    for b in bars:
        c = b["cells"]
        cells = [b["dataset"] + (" (stock-relative)" if b["stock_relative"]
                                 else ""),
                 "–" if b["seed"] is None else str(b["seed"]),
                 c["registered"], c["auc@3"], c["beyond"], c["position"],
                 c["time"], c["moved"], b["result"]]
        lines.append(tables.table_row(cells))
    lines += ["", bars_note(), "", all_bars_met(bars)[1]]
    return "\n".join(lines) + "\n"
