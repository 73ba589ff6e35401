"""Statistics of the runs: medians and spreads over seeds and repeats, and
the log-log slope of a figure against the number of images."""

import math
import statistics


def median(values):
    """Median of the non-None values (None if none); an int when the values
    are ints and the median is whole (counts stay counts)."""
    values = [v for v in values if v is not None]
    if not values:
        return None
    result = statistics.median(values)
    if all(isinstance(v, int) for v in values) and result == int(result):
        return int(result)
    return result


def median_time_run(runs):
    """The run whose wall time is the median (the lower middle one for an
    even count)."""
    timed = [r for r in runs if r.get("wall_time_s") is not None] or runs
    order = sorted(timed, key=lambda r: r.get("wall_time_s") or 0.0)
    return order[(len(order) - 1) // 2]


def fit_slope(points):
    """Least-squares slope of log(value) against log(images) over points
    [(images, value)], skipping values that are None or not positive; None
    with fewer than two distinct sizes."""
    pts = [(math.log(n), math.log(v)) for n, v in points
           if v is not None and v > 0 and n > 0]
    if len({x for x, _ in pts}) < 2:
        return None
    mean_x = sum(x for x, _ in pts) / len(pts)
    mean_y = sum(y for _, y in pts) / len(pts)
    sxx = sum((x - mean_x) ** 2 for x, _ in pts)
    sxy = sum((x - mean_x) * (y - mean_y) for x, y in pts)
    return sxy / sxx
