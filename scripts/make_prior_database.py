#!/usr/bin/env python3
"""Writes SIMULATED camera position priors (fake GPS) into a copy of a COLMAP
3.8 database: ground-truth camera centres plus Gaussian noise, for testing how
a mapper uses position priors on real image sets. These are NOT real GPS
measurements.

The input database is never opened, only copied byte for byte (with its -wal
file, if one holds data) to --output_path; the copy gets the priors in the
images table's prior_tx, prior_ty, prior_tz, where COLMAP 3.8 keeps them.
Every prior already in the copy is cleared first, so images without a ground
truth pose (or picked by --missing_ratio) end with none (NULL).

Ground truth: a COLMAP model folder (images.bin, else images.txt); images are
matched to the database by name. Each image's prior is

  inlier:  centre * --gt_metres_per_unit + N(0, --noise_m^2) per axis,
  outlier: centre * --gt_metres_per_unit + a displacement in a uniformly
           random direction, of length uniform in
           [--outlier_min_m, --outlier_max_m] (no noise on top),
  missing: none,

with round(ratio * images) outliers and missing images, all drawn from
--seed (each image's noise from its own stream, keyed by its name, so the
ratios do not change the other images' noise). Priors are stored in metres in
the ground-truth frame, or with --as_gps as latitude (deg), longitude (deg),
altitude (m, WGS84 ellipsoid) the way COLMAP's feature extractor stores EXIF
GPS: the ground-truth frame (turned so that --gt_up_axis points up) is taken
as east-north-up around --gps_origin and converted with the formulas of COLMAP
3.8's GPSTransform(WGS84). A reader gets the metric positions back with
GPSTransform(WGS84).EllToENU({origin, lla...}, lat0, lon0) (in COLMAP 3.8 it
measures from its first point, so the origin goes first).

Priors are in metres: the dataset's README (beside gt/) must say that the
ground truth is in metres, else the script warns (pass --gt_metres_per_unit
if it is not).

Beside the output, <output_path>.priors.txt lists per image the kind of its
prior (inlier, outlier, missing), its true centre and its metric prior, as
make_synthetic_scene's priors.txt does.

Example:
    scripts/make_prior_database.py \\
        --database_path ../shared/datasets/KITTI_sequence_1/database.db \\
        --gt_path ../shared/datasets/KITTI_sequence_1/gt \\
        --output_path /tmp/kitti_priors.db --noise_m 2 --seed 0

Check the script's own logic (no dataset needed): --self_test.

Only the Python standard library is used.
"""

import argparse
import contextlib
import hashlib
import io
import math
import os
import random
import re
import shutil
import sqlite3
import struct
import sys
import tempfile

SIMULATED = "SIMULATED position priors (ground truth + noise, not real GPS)"

# WGS84, as in COLMAP 3.8's GPSTransform.
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)

# Axes of the ground-truth frame that may point up, with the rotation that
# takes ground-truth coordinates to east-north-up (rows: east, north, up;
# proper rotations, determinant +1).
UP_AXES = {
    "+z": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "-z": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),
    "+y": ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    "-y": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
    "+x": ((0, 1, 0), (0, 0, 1), (1, 0, 0)),
    "-x": ((0, 1, 0), (0, 0, -1), (-1, 0, 0)),
}

METRE_RE = re.compile(r"\b(metres?|meters?|metric)\b", re.IGNORECASE)
GT_RE = re.compile(r"ground[- ]truth|\bgt/", re.IGNORECASE)


def log(message):
    print(message, flush=True)


def warn(message):
    print("WARNING: " + message, file=sys.stderr, flush=True)


# --- Geometry ---------------------------------------------------------------

def quaternion_to_rotation(qw, qx, qy, qz):
    """Rotation matrix (rows) of a unit quaternion, as COLMAP's
    QuaternionToRotationMatrix (Hamilton, w first)."""
    norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    qw, qx, qy, qz = qw / norm, qx / norm, qy / norm, qz / norm
    return (
        (1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz),
         2 * (qx * qz + qw * qy)),
        (2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz),
         2 * (qy * qz - qw * qx)),
        (2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx),
         1 - 2 * (qx * qx + qy * qy)),
    )


def mat_vec(matrix, vector):
    return tuple(sum(row[k] * vector[k] for k in range(3)) for row in matrix)


def mat_t_vec(matrix, vector):
    return tuple(sum(matrix[k][i] * vector[k] for k in range(3))
                 for i in range(3))


def projection_center(qvec, tvec):
    """Camera centre -R^T t of a cam_from_world pose."""
    rotation = quaternion_to_rotation(*qvec)
    return tuple(-c for c in mat_t_vec(rotation, tvec))


def norm(vector):
    return math.sqrt(sum(c * c for c in vector))


def ell_to_xyz(lat_deg, lon_deg, alt_m):
    """Latitude, longitude, altitude (WGS84) to ECEF, as GPSTransform."""
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    n = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(lat) ** 2)
    return ((n + alt_m) * math.cos(lat) * math.cos(lon),
            (n + alt_m) * math.cos(lat) * math.sin(lon),
            (n * (1 - WGS84_E2) + alt_m) * math.sin(lat))


def xyz_to_ell(x, y, z):
    """ECEF to latitude, longitude, altitude: GPSTransform::XYZToEll's
    iteration (with the altitude initialised, which 3.8 forgets)."""
    radius_xy = math.hypot(x, y)
    lat = math.atan2(z, radius_xy)
    alt = 0.0
    for _ in range(100):
        n = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(lat) ** 2)
        prev_lat, prev_alt = lat, alt
        alt = radius_xy / math.cos(lat) - n
        lat = math.atan((z / radius_xy) / (1 - WGS84_E2 * n / (n + alt)))
        if abs(prev_lat - lat) < 1e-12 and abs(prev_alt - alt) < 1e-12:
            break
    return math.degrees(lat), math.degrees(math.atan2(y, x)), alt


def ecef_to_enu_rotation(lat0_deg, lon0_deg):
    lat0, lon0 = math.radians(lat0_deg), math.radians(lon0_deg)
    return ((-math.sin(lon0), math.cos(lon0), 0.0),
            (-math.sin(lat0) * math.cos(lon0), -math.sin(lat0) * math.sin(lon0),
             math.cos(lat0)),
            (math.cos(lat0) * math.cos(lon0), math.cos(lat0) * math.sin(lon0),
             math.sin(lat0)))


def enu_to_ell(enu, origin):
    """GPSTransform::ENUToEll: east-north-up metres around origin (lat deg,
    lon deg, alt m) to latitude, longitude, altitude."""
    reference = ell_to_xyz(*origin)
    rotation = ecef_to_enu_rotation(origin[0], origin[1])
    offset = mat_t_vec(rotation, enu)
    return xyz_to_ell(*(reference[k] + offset[k] for k in range(3)))


def ell_to_enu(ell, origin):
    """GPSTransform::EllToENU({origin, ell}, lat0, lon0)[1]: back to metres."""
    reference = ell_to_xyz(*origin)
    xyz = ell_to_xyz(*ell)
    rotation = ecef_to_enu_rotation(origin[0], origin[1])
    return mat_vec(rotation, tuple(xyz[k] - reference[k] for k in range(3)))


# --- Ground truth -----------------------------------------------------------

def read_images_bin(path):
    """{name: (qvec, tvec)} of a COLMAP images.bin."""
    poses = {}
    with open(path, "rb") as f:
        data = f.read()
    offset = 0

    def take(fmt):
        nonlocal offset
        size = struct.calcsize(fmt)
        if offset + size > len(data):
            raise ValueError("truncated " + path)
        values = struct.unpack_from(fmt, data, offset)
        offset += size
        return values

    (count,) = take("<Q")
    for _ in range(count):
        values = take("<I7dI")
        end = data.find(b"\0", offset)
        if end < 0:
            raise ValueError("truncated " + path)
        name = data[offset:end].decode("utf-8")
        offset = end + 1
        (num_points,) = take("<Q")
        offset += 24 * num_points
        poses[name] = (values[1:5], values[5:8])
    if offset > len(data):
        raise ValueError("truncated " + path)
    return poses


def read_images_txt(path):
    """{name: (qvec, tvec)} of a COLMAP images.txt, read as COLMAP does: a
    pose line (comments and empty lines skipped), then one line of 2-D
    points, whatever it holds."""
    poses = {}
    with open(path, errors="replace") as f:
        lines = f.read().split("\n")
    k = 0
    while k < len(lines):
        line = lines[k].strip()
        k += 1
        if not line or line.startswith("#"):
            continue
        fields = line.split(None, 9)
        if len(fields) != 10:
            raise ValueError("bad image line in %s: %r" % (path, line))
        values = [float(v) for v in fields[1:8]]
        poses[fields[9]] = (tuple(values[0:4]), tuple(values[4:7]))
        k += 1  # the points line
    return poses


def read_gt_poses(gt_path):
    for name, reader in (("images.bin", read_images_bin),
                         ("images.txt", read_images_txt)):
        path = os.path.join(gt_path, name)
        if os.path.isfile(path):
            return path, reader(path)
    raise FileNotFoundError("no images.bin or images.txt in " + gt_path)


def gt_unit_statement(gt_path):
    """(README path, the README line that says the ground truth is in metres,
    or None). The README is the dataset's, beside gt/ (or in it)."""
    gt_path = os.path.abspath(gt_path)
    for folder in (os.path.dirname(gt_path), gt_path):
        readme = os.path.join(folder, "README.md")
        if not os.path.isfile(readme):
            continue
        with open(readme, errors="replace") as f:
            for line in f:
                if GT_RE.search(line) and METRE_RE.search(line):
                    return readme, line.strip()
        return readme, None
    return None, None


def mean_camera_up(poses):
    """Mean of the cameras' up direction (-y of the camera) in the ground
    truth frame."""
    total = [0.0, 0.0, 0.0]
    for qvec, _ in poses.values():
        rotation = quaternion_to_rotation(*qvec)
        for k in range(3):
            total[k] -= rotation[1][k]
    return tuple(c / max(1, len(poses)) for c in total)


def dominant_axis(vector):
    k = max(range(3), key=lambda i: abs(vector[i]))
    return ("+" if vector[k] > 0 else "-") + "xyz"[k]


# --- Priors -----------------------------------------------------------------

def simulate_priors(centres_m, noise_m, outlier_ratio, outlier_min_m,
                    outlier_max_m, missing_ratio, seed):
    """{name: (kind, prior or None)} for {name: metric centre}."""
    names = sorted(centres_m)
    order = list(names)
    random.Random("%d:selection" % seed).shuffle(order)
    num_missing = min(len(names), int(math.floor(missing_ratio * len(names)
                                                  + 0.5)))
    num_outliers = min(len(names) - num_missing,
                       int(math.floor(outlier_ratio * len(names) + 0.5)))
    missing = set(order[:num_missing])
    outliers = set(order[num_missing:num_missing + num_outliers])
    priors = {}
    for name in names:
        # Every image draws its noise and displacement from its own stream.
        rng = random.Random("%d:noise:%s" % (seed, name))
        noise = [rng.gauss(0, 1) for _ in range(3)]
        direction = [rng.gauss(0, 1) for _ in range(3)]
        length = rng.uniform(outlier_min_m, outlier_max_m)
        centre = centres_m[name]
        if name in missing:
            priors[name] = ("missing", None)
        elif name in outliers:
            scale = length / max(norm(direction), 1e-12)
            priors[name] = ("outlier", tuple(centre[k] + scale * direction[k]
                                             for k in range(3)))
        else:
            priors[name] = ("inlier", tuple(centre[k] + noise_m * noise[k]
                                            for k in range(3)))
    return priors


def copy_database(source, destination):
    """Byte copy of a database and of its -wal file if that holds data (a
    WAL-mode database keeps committed pages there until a checkpoint). The
    source is never opened by sqlite: even a read-only open of a WAL-mode
    database creates -shm and -wal files beside it."""
    shutil.copyfile(source, destination)
    for suffix in ("-wal", "-shm", "-journal"):
        if os.path.exists(destination + suffix):
            os.remove(destination + suffix)
    wal = source + "-wal"
    if os.path.isfile(wal) and os.path.getsize(wal) > 0:
        shutil.copyfile(wal, destination + "-wal")


def write_priors_txt(path, args, gt_file, centres_m, priors, db_names):
    with open(path, "w") as f:
        f.write("# %s, written by scripts/make_prior_database.py.\n"
                % SIMULATED)
        f.write("# Ground truth: %s (metres per unit %g); units: metres; "
                "frame: the ground truth's.\n" % (gt_file,
                                                  args.gt_metres_per_unit))
        f.write("# noise_m %g outlier_ratio %g outlier_min_m %g "
                "outlier_max_m %g missing_ratio %g seed %d\n" % (
                    args.noise_m, args.outlier_ratio, args.outlier_min_m,
                    args.outlier_max_m, args.missing_ratio, args.seed))
        if args.as_gps:
            f.write("# The database stores them as GPS (prior_tx, prior_ty, "
                    "prior_tz = latitude deg, longitude deg, WGS84 altitude "
                    "m): ground-truth frame turned so that %s is up, as "
                    "east-north-up around the origin %.10g %.10g %.10g\n" % (
                        args.gt_up_axis, *args.gps_origin))
        else:
            f.write("# The database stores them as they are here (prior_tx, "
                    "prior_ty, prior_tz in metres).\n")
        f.write("# KIND: inlier (true centre + noise), outlier (displaced), "
                "missing (NULL in the database; prior and error nan).\n")
        f.write("# IMAGE_ID NAME KIND TRUE_X TRUE_Y TRUE_Z PRIOR_X PRIOR_Y "
                "PRIOR_Z ERROR_M\n")
        for name in sorted(priors, key=lambda n: db_names[n]):
            kind, prior = priors[name]
            centre = centres_m[name]
            if prior is None:
                prior_text = "nan nan nan nan"
            else:
                error = norm([prior[k] - centre[k] for k in range(3)])
                prior_text = "%.6f %.6f %.6f %.6f" % (*prior, error)
            f.write("%d %s %s %.6f %.6f %.6f %s\n" % (
                db_names[name], name, kind, *centre, prior_text))


def make_prior_database(args):
    """Does the work; returns {name: (kind, metric prior or None)}."""
    if not os.path.isfile(args.database_path):
        raise SystemExit("error: no database at " + args.database_path)
    if os.path.exists(args.output_path):
        if os.path.realpath(args.output_path) == os.path.realpath(
                args.database_path) or os.path.samefile(args.output_path,
                                                        args.database_path):
            raise SystemExit("error: --output_path is the input database; "
                             "the input is never modified")
        if not args.overwrite:
            raise SystemExit("error: %s exists (pass --overwrite to replace "
                             "it)" % args.output_path)
    gt_file, poses = read_gt_poses(args.gt_path)

    readme, statement = gt_unit_statement(args.gt_path)
    if statement is not None:
        log("Ground truth in metres, says %s: %s" % (readme, statement))
    elif args.gt_metres_per_unit_given:
        log("Ground truth unit: %g m (--gt_metres_per_unit)"
            % args.gt_metres_per_unit)
    else:
        warn("%s does not say that the ground truth is in metres; the "
             "priors take its unit for a metre (pass --gt_metres_per_unit "
             "if it is not)" % (readme or "no README.md beside " +
                                args.gt_path + ":"))
    if args.as_gps:
        up = mean_camera_up(poses)
        if norm(up) > 0.5 and dominant_axis(up) != args.gt_up_axis:
            warn("the cameras' mean up direction is %s of the ground-truth "
                 "frame, but --gt_up_axis is %s: if the images were taken "
                 "upright (not nadir), pass --gt_up_axis=%s, else altitudes "
                 "follow a horizontal axis" % (dominant_axis(up),
                                               args.gt_up_axis,
                                               dominant_axis(up)))

    copy_database(args.database_path, args.output_path)
    connection = sqlite3.connect(args.output_path)
    try:
        db_names = {name: image_id for image_id, name in connection.execute(
            "SELECT image_id, name FROM images")}
        num_old_priors = connection.execute(
            "SELECT COUNT(*) FROM images WHERE prior_tx IS NOT NULL OR "
            "prior_ty IS NOT NULL OR prior_tz IS NOT NULL").fetchone()[0]
        matched = sorted(set(db_names) & set(poses))
        if not matched:
            raise SystemExit("error: no image of %s has a ground-truth pose "
                             "in %s (images are matched by name)" % (
                                 args.database_path, gt_file))
        centres_m = {}
        for name in matched:
            centre = projection_center(*poses[name])
            centres_m[name] = tuple(args.gt_metres_per_unit * c
                                    for c in centre)
        priors = simulate_priors(centres_m, args.noise_m, args.outlier_ratio,
                                 args.outlier_min_m, args.outlier_max_m,
                                 args.missing_ratio, args.seed)
        to_enu = UP_AXES[args.gt_up_axis]
        with connection:
            connection.execute("UPDATE images SET prior_tx = NULL, "
                               "prior_ty = NULL, prior_tz = NULL")
            for name, (kind, prior) in priors.items():
                if prior is None:
                    continue
                stored = prior
                if args.as_gps:
                    stored = enu_to_ell(mat_vec(to_enu, prior),
                                        args.gps_origin)
                connection.execute(
                    "UPDATE images SET prior_tx = ?, prior_ty = ?, "
                    "prior_tz = ? WHERE image_id = ?",
                    (*stored, db_names[name]))
        readback = connection.execute(
            "SELECT image_id, name, prior_tx, prior_ty, prior_tz FROM images "
            "ORDER BY image_id LIMIT 3").fetchall()
    finally:
        connection.close()

    write_priors_txt(args.output_path + ".priors.txt", args, gt_file,
                     centres_m, priors, db_names)
    kinds = [kind for kind, _ in priors.values()]
    log("Wrote %s to %s:" % (SIMULATED, args.output_path))
    log("  %d images with a ground-truth pose (of %d in the database, %d in "
        "%s); noise %g m per axis, seed %d" % (
            len(matched), len(db_names), len(poses), gt_file, args.noise_m,
            args.seed))
    log("  %d inliers, %d outliers (displaced %g to %g m), %d without a "
        "prior; %d image(s) without a ground-truth pose have none" % (
            kinds.count("inlier"), kinds.count("outlier"), args.outlier_min_m,
            args.outlier_max_m, kinds.count("missing"),
            len(db_names) - len(matched)))
    if num_old_priors:
        log("  the input had position priors in %d image(s); all were "
            "replaced" % num_old_priors)
    if args.as_gps:
        log("  stored as latitude, longitude, altitude (WGS84): ground "
            "truth with %s up as east-north-up around %.10g, %.10g, %.10g m"
            % (args.gt_up_axis, *args.gps_origin))
    else:
        log("  stored in metres in the ground-truth frame")
    outlier_names = sorted(n for n, (k, _) in priors.items() if k == "outlier")
    if outlier_names:
        log("  outliers: " + " ".join(outlier_names))
    log("  list of all priors with their truth: %s.priors.txt"
        % args.output_path)
    log("  read back (image_id, name, prior_tx, prior_ty, prior_tz):")
    for row in readback:
        log("    %s" % (row,))
    return priors


# --- Command line -----------------------------------------------------------

def parse_origin(text):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if (len(values) != 3 or not all(math.isfinite(v) for v in values)
            or abs(values[0]) >= 90 or abs(values[1]) > 180):
        raise argparse.ArgumentTypeError(
            "need latitude,longitude,altitude (deg, deg, m): %r" % text)
    return tuple(values)


def non_negative(text):
    try:
        value = float(text)
    except ValueError:
        value = -1
    if not value >= 0 or not math.isfinite(value):
        raise argparse.ArgumentTypeError("need a number >= 0: %r" % text)
    return value


def ratio(text):
    value = non_negative(text)
    if value > 1:
        raise argparse.ArgumentTypeError("need a ratio in [0, 1]: %r" % text)
    return value


def build_parser():
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="\n\n".join(__doc__.split("\n\n")[1:]),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--database_path",
                        help="the dataset's database.db (only copied)")
    parser.add_argument("--gt_path", help="ground-truth COLMAP model folder "
                        "(images.bin or images.txt)")
    parser.add_argument("--output_path", help="the new database with "
                        "simulated priors")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace --output_path if it exists")
    parser.add_argument("--noise_m", type=non_negative, default=2.0,
                        help="standard deviation of the simulated GPS noise "
                        "per axis, metres (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0,
                        help="random seed (default: %(default)s)")
    parser.add_argument("--outlier_ratio", type=ratio, default=0.0,
                        help="fraction of the images whose prior is "
                        "displaced (default: %(default)s)")
    parser.add_argument("--outlier_min_m", type=non_negative, default=20.0,
                        help="shortest outlier displacement, metres "
                        "(default: %(default)s)")
    parser.add_argument("--outlier_max_m", type=non_negative, default=100.0,
                        help="longest outlier displacement, metres "
                        "(default: %(default)s)")
    parser.add_argument("--missing_ratio", type=ratio, default=0.0,
                        help="fraction of the images left without a prior "
                        "(default: %(default)s)")
    parser.add_argument("--as_gps", action="store_true",
                        help="store latitude, longitude, altitude (WGS84) "
                        "around --gps_origin instead of metres")
    parser.add_argument("--gps_origin", type=parse_origin,
                        default=(47.3769, 8.5417, 400.0),
                        metavar="LAT,LON,ALT", help="origin of the "
                        "east-north-up frame for --as_gps (default: "
                        "47.3769,8.5417,400; write --gps_origin=-33.9,18.4,10 "
                        "for a negative latitude)")
    parser.add_argument("--gt_up_axis", choices=sorted(UP_AXES),
                        default="+z", help="axis of the ground-truth frame "
                        "that points up, for --as_gps (KITTI and other "
                        "camera-frame ground truths: -y; default: "
                        "%(default)s)")
    parser.add_argument("--gt_metres_per_unit", type=float, default=None,
                        help="metres per ground-truth unit (default: 1; "
                        "give it when the dataset's README does not say "
                        "metres)")
    parser.add_argument("--self_test", action="store_true",
                        help="check the script on a tiny made-up database, "
                        "then exit")
    return parser


def parse_args(argv):
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.self_test:
        return args
    for name in ("database_path", "gt_path", "output_path"):
        if getattr(args, name) is None:
            parser.error("--%s is required" % name)
    if args.outlier_min_m > args.outlier_max_m:
        parser.error("--outlier_min_m must be at most --outlier_max_m")
    if args.outlier_ratio + args.missing_ratio > 1:
        parser.error("--outlier_ratio + --missing_ratio must be at most 1")
    args.gt_metres_per_unit_given = args.gt_metres_per_unit is not None
    if args.gt_metres_per_unit is None:
        args.gt_metres_per_unit = 1.0
    if not (args.gt_metres_per_unit > 0 and
            math.isfinite(args.gt_metres_per_unit)):
        parser.error("--gt_metres_per_unit must be > 0")
    return args


# --- Self-test --------------------------------------------------------------

# The images table of COLMAP 3.8 (base/database.cc).
IMAGES_TABLE = (
    "CREATE TABLE images (image_id INTEGER PRIMARY KEY AUTOINCREMENT NOT "
    "NULL, name TEXT NOT NULL UNIQUE, camera_id INTEGER NOT NULL, prior_qw "
    "REAL, prior_qx REAL, prior_qy REAL, prior_qz REAL, prior_tx REAL, "
    "prior_ty REAL, prior_tz REAL, CONSTRAINT image_id_check CHECK(image_id "
    ">= 0 and image_id < 2147483647))")


def file_sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def self_test():
    checks = [0]

    def expect(condition, what):
        checks[0] += 1
        if not condition:
            raise AssertionError("self-test failed: " + what)

    # Geometry: rotations are proper, poses give their centres, GPS round
    # trips below a millimetre and agrees with the meridian radius.
    for axis, rows in UP_AXES.items():
        det = (rows[0][0] * (rows[1][1] * rows[2][2] - rows[1][2] * rows[2][1])
               - rows[0][1] * (rows[1][0] * rows[2][2] - rows[1][2] * rows[2][0])
               + rows[0][2] * (rows[1][0] * rows[2][1] - rows[1][1] * rows[2][0]))
        expect(det == 1, "rotation of %s is proper" % axis)
        up_index = "xyz".index(axis[1])
        up = [0, 0, 0]
        up[up_index] = 1 if axis[0] == "+" else -1
        expect(mat_vec(rows, up) == (0, 0, 1), "%s goes up" % axis)
    rng = random.Random(1)
    for _ in range(20):
        qvec = [rng.gauss(0, 1) for _ in range(4)]
        centre = [rng.uniform(-50, 50) for _ in range(3)]
        rotation = quaternion_to_rotation(*qvec)
        tvec = tuple(-c for c in mat_vec(rotation, centre))
        expect(norm([a - b for a, b in zip(projection_center(qvec, tvec),
                                           centre)]) < 1e-9, "centre")
    max_error = 0
    for origin in ((47.3769, 8.5417, 400.0), (-33.9249, -70.6693, 520.0),
                   (0.0, 179.9, -10.0), (78.2, 15.6, 0.0)):
        expect(norm(ell_to_enu(origin, origin)) < 1e-6, "origin is 0")
        for _ in range(50):
            enu = (rng.uniform(-5000, 5000), rng.uniform(-5000, 5000),
                   rng.uniform(-100, 500))
            back = ell_to_enu(enu_to_ell(enu, origin), origin)
            max_error = max(max_error, norm([a - b for a, b in zip(back, enu)]))
        lat = math.radians(origin[0])
        meridian_radius = (WGS84_A * (1 - WGS84_E2) /
                           (1 - WGS84_E2 * math.sin(lat) ** 2) ** 1.5)
        north = enu_to_ell((0, 100, 0), origin)
        expect(abs(math.radians(north[0] - origin[0]) *
                   (meridian_radius + origin[2]) - 100) < 1e-3,
               "100 m north at %s" % (origin,))
        up = enu_to_ell((0, 0, 30), origin)
        expect(abs(up[2] - origin[2] - 30) < 1e-6 and
               abs(up[0] - origin[0]) < 1e-9, "30 m up")
    expect(max_error < 1e-3, "GPS round trip %g m" % max_error)
    # Points whose ECEF coordinates are the ellipsoid's axes.
    semi_minor = WGS84_A * (1 - WGS84_F)
    for ell, xyz in (((0, 0, 0), (WGS84_A, 0, 0)),
                     ((0, 90, 10), (0, WGS84_A + 10, 0)),
                     ((90, 0, 0), (0, 0, semi_minor))):
        expect(norm([a - b for a, b in zip(ell_to_xyz(*ell), xyz)]) < 1e-6,
               "ECEF of %s" % (ell,))

    with tempfile.TemporaryDirectory() as tmp:
        dataset = os.path.join(tmp, "dataset")
        gt = os.path.join(dataset, "gt")
        os.makedirs(gt)
        database = os.path.join(dataset, "database.db")
        # A WAL-mode database with an old prior, as real ones may be.
        connection = sqlite3.connect(database)
        connection.execute("PRAGMA journal_mode=WAL")
        connection.execute(IMAGES_TABLE)
        names = ["img%02d.jpg" % k for k in range(40)] + ["no gt.jpg"]
        for k, name in enumerate(names):
            connection.execute("INSERT INTO images(image_id, name, camera_id)"
                               " VALUES(?, ?, 1)", (k + 1, name))
        connection.execute("UPDATE images SET prior_tx = 1, prior_ty = 2, "
                           "prior_tz = 3 WHERE name = 'no gt.jpg'")
        connection.commit()
        connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        connection.close()
        for suffix in ("-wal", "-shm"):
            if os.path.exists(database + suffix):
                os.remove(database + suffix)
        poses = {}
        for k, name in enumerate(names[:40] + ["not in db.jpg"]):
            qvec = tuple(rng.gauss(0, 1) for _ in range(4))
            qvec = tuple(q / norm(qvec) for q in qvec)
            centre = (k * 1.0, 5 * math.sin(k / 5), 1.5)
            rotation = quaternion_to_rotation(*qvec)
            poses[name] = (qvec, tuple(-c for c in mat_vec(rotation, centre)))
        with open(os.path.join(gt, "images.txt"), "w") as f:
            f.write("# Image list with two lines of data per image:\n")
            for k, (name, (qvec, tvec)) in enumerate(poses.items()):
                f.write("%d %s 1 %s\n" % (k + 1, " ".join(
                    "%.17g" % v for v in qvec + tvec), name))
                f.write("1.0 2.0 -1 3.0 4.0 -1\n" if k % 2 else "\n")
        with open(os.path.join(gt, "images.bin"), "wb") as f:
            f.write(struct.pack("<Q", len(poses)))
            for k, (name, (qvec, tvec)) in enumerate(poses.items()):
                f.write(struct.pack("<I7dI", k + 1, *qvec, *tvec, 1))
                f.write(name.encode() + b"\0" + struct.pack("<Q", k % 3))
                f.write(struct.pack("<ddq", 1, 2, -1) * (k % 3))
        txt_poses = read_images_txt(os.path.join(gt, "images.txt"))
        bin_poses = read_images_bin(os.path.join(gt, "images.bin"))
        expect(txt_poses.keys() == bin_poses.keys() == poses.keys(),
               "names of images.txt and images.bin")
        expect(all(norm([a - b for a, b in zip(txt_poses[n][1],
                                               bin_poses[n][1])]) < 1e-12
                   for n in poses), "poses of images.txt and images.bin")

        expect(gt_unit_statement(gt) == (None, None), "no README")
        with open(os.path.join(dataset, "README.md"), "w") as f:
            f.write("# x\n- Ground truth: `gt/` as a COLMAP text model, "
                    "units as the source (arbitrary).\n- 3 metres wide.\n")
        expect(gt_unit_statement(gt)[1] is None, "README without metres")
        with open(os.path.join(dataset, "README.md"), "w") as f:
            f.write("# x\n- Ground truth: `gt/` as a COLMAP text model "
                    "(cameras and poses; no points), units as the source "
                    "(metres).\n")
        expect(gt_unit_statement(gt)[1] is not None, "README with metres")

        before = file_sha256(database)
        listing = sorted(os.listdir(dataset))
        output = os.path.join(tmp, "out", "priors.db")
        os.makedirs(os.path.dirname(output))
        base = ["--database_path", database, "--gt_path", gt,
                "--output_path", output]

        def read_priors(path):
            connection = sqlite3.connect(path)
            try:
                return {name: (tx, ty, tz) for name, tx, ty, tz in
                        connection.execute("SELECT name, prior_tx, prior_ty, "
                                           "prior_tz FROM images")}
            finally:
                connection.close()

        centres = {n: projection_center(*poses[n]) for n in names[:40]}
        outputs = []

        def run(argv):
            text = io.StringIO()
            with contextlib.redirect_stdout(text):
                with contextlib.redirect_stderr(text):
                    result = make_prior_database(parse_args(argv))
            outputs.append(text.getvalue())
            return result

        # Without noise the priors are the centres.
        run(base + ["--noise_m", "0"])
        expect("SIMULATED" in outputs[-1] and "not real GPS" in outputs[-1]
               and "WARNING" not in outputs[-1], "output:\n" + outputs[-1])
        stored = read_priors(output)
        expect(all(norm([a - b for a, b in zip(stored[n], centres[n])])
                   < 1e-9 for n in centres), "exact priors")
        expect(stored["no gt.jpg"] == (None, None, None),
               "old prior of an image without ground truth cleared")
        try:
            run(base)
            expect(False, "an existing output is refused")
        except SystemExit as error:
            expect("exists" in str(error), "an existing output is refused")
        try:
            run(["--database_path", database, "--gt_path", gt,
                 "--output_path", database, "--overwrite"])
            expect(False, "the input as output is refused")
        except SystemExit as error:
            expect("input" in str(error), "the input as output is refused")

        # Noise, outliers, missing priors.
        priors = run(base + [
            "--overwrite", "--noise_m", "0.5", "--seed", "3",
            "--outlier_ratio", "0.2", "--outlier_min_m", "20",
            "--outlier_max_m", "30", "--missing_ratio", "0.1"])
        stored = read_priors(output)
        kinds = {n: k for n, (k, _) in priors.items()}
        expect(sorted(kinds.values()).count("outlier") == 8 and
               sorted(kinds.values()).count("missing") == 4, "counts")
        squared = []
        for name, kind in kinds.items():
            if kind == "missing":
                expect(stored[name] == (None, None, None), "missing " + name)
                continue
            error = norm([a - b for a, b in zip(stored[name], centres[name])])
            if kind == "outlier":
                expect(20 - 1e-9 <= error <= 30 + 1e-9, "outlier " + name)
            else:
                squared.append(error ** 2)
                expect(error < 5 * 0.5 * math.sqrt(3), "inlier " + name)
        rms = math.sqrt(sum(squared) / len(squared))
        expect(0.6 * 0.5 * math.sqrt(3) < rms < 1.4 * 0.5 * math.sqrt(3),
               "noise level %g" % rms)
        with open(output + ".priors.txt") as f:
            rows = [line.split() for line in f if not line.startswith("#")]
        expect(len(rows) == 40 and {r[1]: r[2] for r in rows} == kinds,
               "priors.txt")
        # The same seed gives the same priors; the noise level scales them.
        again = run(base + [
            "--overwrite", "--noise_m", "1", "--seed", "3",
            "--outlier_ratio", "0.2", "--outlier_min_m", "20",
            "--outlier_max_m", "30", "--missing_ratio", "0.1"])
        for name, (kind, prior) in priors.items():
            expect(again[name][0] == kind, "same kinds")
            if kind == "inlier":
                expect(norm([(a - c) - 2 * (b - c) for a, b, c in zip(
                    again[name][1], prior, centres[name])]) < 1e-9,
                    "noise scales")

        # As GPS, ground truth with -y up (a camera frame).
        priors = run(base + [
            "--overwrite", "--noise_m", "0", "--as_gps", "--gt_up_axis=-y",
            "--gps_origin=-33.9249,18.4241,12"])
        stored = read_priors(output)
        origin = (-33.9249, 18.4241, 12.0)
        for name in centres:
            enu = ell_to_enu(stored[name], origin)
            expected = mat_vec(UP_AXES["-y"], centres[name])
            expect(norm([a - b for a, b in zip(enu, expected)]) < 1e-3,
                   "GPS round trip of " + name)
            expect(abs(stored[name][2] - (12 - centres[name][1])) < 0.01,
                   "altitude follows -y")
        expect(stored["no gt.jpg"] == (None, None, None), "no gt, no GPS")
        expect("latitude, longitude, altitude" in outputs[-1], "GPS output")
        # A README that does not say metres gives a warning.
        with open(os.path.join(dataset, "README.md"), "w") as f:
            f.write("# x\n- Ground truth: poses (units unknown).\n")
        run(base + ["--overwrite"])
        expect("WARNING" in outputs[-1] and "metres" in outputs[-1],
               "unit warning:\n" + outputs[-1])
        run(base + ["--overwrite", "--noise_m", "0", "--gt_metres_per_unit",
                    "0.01"])
        expect("WARNING" not in outputs[-1], "unit given")
        stored = read_priors(output)
        expect(all(norm([a - 0.01 * b for a, b in zip(stored[n], centres[n])])
                   < 1e-9 for n in centres), "metres per unit")
        with open(os.path.join(dataset, "README.md"), "w") as f:
            f.write("- Ground truth: `gt/` (metres).\n")

        expect(file_sha256(database) == before, "input unchanged")
        expect(sorted(os.listdir(dataset)) == listing,
               "no file added beside the input")
    print("self-test: %d checks passed" % checks[0])


def main():
    args = parse_args(sys.argv[1:])
    if args.self_test:
        self_test()
        return
    make_prior_database(args)


if __name__ == "__main__":
    main()
