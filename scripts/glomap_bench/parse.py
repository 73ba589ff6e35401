"""Text the benchmarks read: the global mapper's log (its stage lines and
final line, also while it grows), the generator's summary line, and the
reference figures in a dataset's README."""

import os
import re

# The global mapper's last line, e.g. "Global mapper finished in 12.3 s: 1
# model(s), 47 of 47 images registered; pose verification re-placed 0 and
# left out 0 image(s)." (older binaries end after "registered").
FINISH_RE = re.compile(
    r"Global mapper finished in\s+([0-9.]+)\s*s:\s*(\d+)\s+model\(s\),\s*"
    r"(\d+)\s+of\s+(\d+)\s+images registered"
    r"(?:;\s*pose verification re-placed\s+(\d+)\s+and left out\s+(\d+))?")

# Tolerant match of the global mapper's stage lines, e.g.
# "Stage rotation_averaging: 1.23 s (...)" or "Stage Rotation averaging : 1.2s"
# possibly behind a glog prefix.
STAGE_RE = re.compile(
    r"Stage\s+[\"'`]?([A-Za-z][\w \-/]*?)[\"'`]?\s*:\s*([0-9]+(?:\.[0-9]*)?"
    r"(?:[eE][-+]?[0-9]+)?)\s*s\b")

# The mapper's line at the start of a stage, e.g. "I1201 12:00:00.1
# global_mapper.cc:28] Stage Rotation averaging ..."; the end line is
# STAGE_RE ("Stage Rotation averaging: 1.234 s (...)").
STAGE_BEGIN_RE = re.compile(r"\bStage\s+([A-Za-z][\w \-/]*?)\s*\.\.\.\s*$")

# The generator's summary line.
GENERATOR_RE = re.compile(r"Wrote\s+(\d+)\s+images,\s*(\d+)\s+cameras,\s*"
                          r"(\d+)\s+points,\s*(\d+)\s+verified pairs")

# Name of the time and memory outside every stage.
OTHER = "other"
# Memory samples before the first stage (process start, reading the
# options): kept in results.json, not in the tables (OTHER is what comes
# between and after the stages).
STARTUP = "start-up"


def stage_key(name):
    """A stage's name as the records keep it ("Rotation averaging" ->
    "rotation_averaging")."""
    return name.strip().replace(" ", "_").lower()


def parse_stages(log_path):
    """[[stage key, seconds]] of the log's stage lines, in log order."""
    stages = []
    with open(log_path, errors="replace") as f:
        for line in f:
            match = STAGE_RE.search(line)
            if match:
                stages.append([stage_key(match.group(1)),
                               float(match.group(2))])
    return stages


def parse_finish(log_path):
    """The counts of the global mapper's final log line (empty if absent)."""
    found = {}
    with open(log_path, errors="replace") as f:
        for line in f:
            match = FINISH_RE.search(line)
            if match:
                found = {"mapper_seconds": float(match.group(1)),
                         "models": int(match.group(2))}
                if match.group(5) is not None:
                    found["replaced_images"] = int(match.group(5))
                    found["left_out_images"] = int(match.group(6))
    return found


def parse_generator_summary(log_path):
    """{"points", "verified_pairs"} of the generator's summary line; empty
    without one."""
    with open(log_path, errors="replace") as f:
        match = GENERATOR_RE.search(f.read())
    if not match:
        return {}
    return {"points": int(match.group(3)),
            "verified_pairs": int(match.group(4))}


def stage_order(records):
    """The stage names of the records' "stages", in first appearance."""
    names = []
    for r in records:
        for name, _ in r.get("stages") or []:
            if name not in names:
                names.append(name)
    return names


def stage_times(record):
    """{stage: seconds} of a record, a repeated stage summed."""
    times = {}
    for name, seconds in record.get("stages") or []:
        times[name] = times.get(name, 0.0) + seconds
    return times


def merged_stages(record):
    """[(stage, seconds)] in log order, a repeated stage summed."""
    times = stage_times(record)
    return [(name, times[name]) for name in stage_order([record])]


class StageTracker:
    """Follows a growing log file and knows which stage is running.
    poll() reads the lines written since the last call and returns (stage,
    whether a stage line was read): STARTUP before the first stage line,
    None between and after the stages."""

    def __init__(self, path):
        self.path = path
        self.offset = 0
        self.partial = ""
        self.current = STARTUP

    def feed(self, text):
        """Processes text appended to the log; whether it held a stage
        line."""
        changed = False
        lines = (self.partial + text).split("\n")
        self.partial = lines.pop()  # Incomplete until its newline arrives.
        for line in lines:
            begin = STAGE_BEGIN_RE.search(line)
            if begin:
                self.current = stage_key(begin.group(1))
                changed = True
            elif STAGE_RE.search(line):
                self.current = None
                changed = True
        return changed

    def poll(self):
        try:
            with open(self.path, "rb") as f:
                f.seek(self.offset)
                data = f.read()
        except OSError:
            data = b""
        self.offset += len(data)
        changed = self.feed(data.decode("utf-8", errors="replace"))
        return self.current, changed


def unfinished_stage(log_path):
    """The stage a log ends in (begun, not finished); None if it ends
    between stages."""
    tracker = StageTracker(log_path)
    stage, _ = tracker.poll()
    return stage if stage != STARTUP else None


def parse_number(cell):
    """The leading number of a table cell ("8.7s", "90.0"); None for "–",
    "failed", ... ."""
    match = re.match(r"\s*(-?[0-9]+(?:\.[0-9]*)?)", cell)
    return float(match.group(1)) if match else None


def reference_row_key(label):
    """"incremental" (COLMAP 3.8's mapper), "upstream" (COLMAP 4.x's
    global_mapper) or None (another row, e.g. this project's) of a reference
    table's row label."""
    lower = label.lower()
    if "this project" in lower:
        return None
    if "incremental" in lower and "3.8" in lower:
        return "incremental"
    if "global_mapper" in lower and ("upstream" in lower or "4.1" in lower):
        return "upstream"
    return None


def parse_reference_text(text):
    """The reference mappers' figures of a dataset README's table:
    {"incremental": row, "upstream": row} (either may be missing), each row
    {"label", "auc@3", "registered": [n, total] or None, "wall_time_s"}.
    Rows of this project's own runs are ignored. None without such rows."""
    rows = {}
    columns = None
    for line in text.splitlines():
        line = line.strip()
        if not line.startswith("|"):
            columns = None  # A table ends.
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        normalized = [c.replace("\\`", "`").replace("°", "").lower()
                      for c in cells]
        if columns is None:
            if any(c.replace(" ", "") == "auc@3" for c in normalized):
                columns = {c.replace(" ", ""): k
                           for k, c in enumerate(normalized)}
            continue
        if all(re.fullmatch(r":?-+:?", c) for c in cells if c):
            continue  # The separator row.
        label = cells[0].replace("\\`", "`")
        key = reference_row_key(label)
        if key is None:
            continue

        def cell(name):
            k = columns.get(name)
            return cells[k] if k is not None and k < len(cells) else ""

        registered = re.match(r"\s*(\d+)\s*/\s*(\d+)", cell("registered"))
        rows[key] = {
            "label": label,
            "auc@3": parse_number(cell("auc@3")),
            "registered": [int(registered.group(1)), int(registered.group(2))]
            if registered else None,
            "wall_time_s": parse_number(cell("walltime")),
        }
    return rows or None


def parse_reference(dataset):
    """parse_reference_text() of the dataset folder's README.md; None
    without one."""
    path = os.path.join(dataset, "README.md")
    if not os.path.isfile(path):
        return None
    with open(path, errors="replace") as f:
        return parse_reference_text(f.read())
