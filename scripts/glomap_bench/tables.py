"""The reports' Markdown: number formats ("–" for a missing figure), table
rows, and the replacement of a report's section in a README."""

import os
import shutil

# Where the plots of a README section are copied, relative to the README.
README_PLOT_DIR = os.path.join("docs", "benchmark")


def fmt(value, digits=1, suffix=""):
    """value with `digits` decimals and the suffix; "–" for None."""
    if value is None:
        return "–"
    return ("%." + str(digits) + "f%s") % (value, suffix)


def fmt_error(value):
    """A position error with 4 significant digits; "–" for None."""
    return "–" if value is None else "%.4g" % value


def fmt_span(values, digits=0):
    """"3" or "2–5" (min–max) of the non-None values; "–" if none."""
    values = [v for v in values if v is not None]
    if not values:
        return "–"
    low, high = fmt(min(values), digits), fmt(max(values), digits)
    return low if low == high else low + "–" + high


def fmt_range(values, digits=1):
    """"min–max" of the non-None values, also when equal."""
    values = [v for v in values if v is not None]
    if not values:
        return "–"
    return fmt(min(values), digits) + "–" + fmt(max(values), digits)


def fmt_deg(value):
    """An angle in degrees with 3 decimals; "–" for None."""
    return "–" if value is None else "%.3f" % value


def fmt_slope(value):
    """A slope with 2 decimals; "–" for None."""
    return "–" if value is None else "%.2f" % value


def table_row(cells):
    """A Markdown table row of the cells (strings)."""
    return "| " + " | ".join(cells) + " |"


def header_rows(names):
    """A Markdown table's header row of the column names and its separator
    row."""
    return [table_row(names), "|" + "---|" * len(names)]


def read_text(path):
    """The text of a file, undecodable bytes replaced."""
    with open(path, errors="replace") as f:
        return f.read()


def copy_plots(readme_path, plots):
    """Copies plots [(path, title, name)] to README_PLOT_DIR/<name> beside
    the README; returns their Markdown image lines, each followed by an
    empty line."""
    readme_dir = os.path.dirname(os.path.abspath(readme_path))
    lines = []
    for path, title, name in plots:
        target = os.path.join(readme_dir, README_PLOT_DIR, name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(path, target)
        lines += ["![%s](%s)" % (title, os.path.relpath(target, readme_dir)),
                  ""]
    return lines


def insert_before(text, block, marker):
    """text with block inserted before the section that begins with marker,
    and before that section's heading if the line above the marker is
    one."""
    head, tail = text.split(marker, 1)
    head_lines = head.rstrip("\n").split("\n")
    if head_lines and head_lines[-1].startswith("#"):
        heading = head_lines.pop()
        head = "\n".join(head_lines).rstrip("\n") + "\n\n"
        tail = heading + "\n\n" + marker + tail
    else:
        tail = marker + tail
    return head + block + "\n\n" + tail


def update_readme_section(readme_path, report, plots, markers, heading,
                          before=None):
    """Replaces the README's section between markers (begin, end) with the
    report: its first paragraph (the provenance), then the plots [(path,
    title, name)] (copy_plots), then the rest of the report. Without the
    section, it is inserted under `heading` before the section that begins
    with the marker `before` (and before that section's heading), or else
    appended."""
    begin, end = markers
    provenance, _, rest = report.partition("\n\n")
    section = [begin, "", provenance, ""]
    section += copy_plots(readme_path, plots)
    section += [rest.rstrip(), "", end]
    block = "\n".join(section)
    text = read_text(readme_path) if os.path.exists(readme_path) else ""
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + block + tail
    elif before and before in text:
        text = insert_before(text, heading + "\n\n" + block, before)
    else:
        text = text.rstrip("\n") + "\n\n" + heading + "\n\n" + block + "\n"
    with open(readme_path, "w") as f:
        f.write(text)
