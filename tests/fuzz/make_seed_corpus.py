#!/usr/bin/env python3
"""Makes the seed corpus of tests/fuzz/database_reader_fuzzer.cc.

Usage: make_seed_corpus.py OUT_DIR [--datasets DIR]

Writes small COLMAP 3.8 databases (one file each, most under 30 KB) to
OUT_DIR:
  - valid_<dataset>.db: 4 images of each shared dataset
    (DIR/<dataset>/database.db, default ../shared/datasets next to the
    repository; read-only, never changed) with the keypoints that their first
    matches use, and those matches, indices remapped consistently;
    valid_generated.db, a tiny made-up database, when no dataset is there;
  - damaged variants of the first of those, one kind of damage each, as
    tests/database_reader_test.cc makes them and more: non-finite keypoints,
    blobs and counts of the wrong size, repeated rows (tables without their
    primary key), out-of-range match indices, pairs naming unknown images,
    unknown configs, NULL/empty/non-finite F, E, H, unusable cameras, unknown
    camera models, missing tables, other column types, UTF-16 text, WAL and
    rollback-journal files, an empty, a truncated and a non-SQLite file.
Only Python's standard library (sqlite3) is used. Safe to run twice: OUT_DIR
is refilled.
"""
import argparse
import math
import os
import shutil
import sqlite3
import struct
import sys

PAIR_ID_FACTOR = 2147483647  # COLMAP 3.8's Database::kMaxNumImages.
NUM_IMAGES = 4
MATCHES_PER_PAIR = 40  # Inlier matches kept per pair (>= 15, the default).
RAW_MATCHES_PER_PAIR = 60

# COLMAP 3.8's schema (Database::CreateTables), used when no dataset is
# there; otherwise the schema is copied from the dataset's database.
COLMAP_38_SCHEMA = [
    "CREATE TABLE cameras   (camera_id            INTEGER  PRIMARY KEY "
    "AUTOINCREMENT  NOT NULL,    model                INTEGER"
    "                             NOT NULL,    width                INTEGER"
    "                             NOT NULL,    height               INTEGER"
    "                             NOT NULL,    params               BLOB,"
    "    prior_focal_length   INTEGER                             NOT NULL)",
    "CREATE TABLE images   (image_id   INTEGER  PRIMARY KEY AUTOINCREMENT  "
    "NOT NULL,    name       TEXT                                NOT NULL "
    "UNIQUE,    camera_id  INTEGER                             NOT NULL,"
    "    prior_qw   REAL,    prior_qx   REAL,    prior_qy   REAL,    prior_qz"
    "   REAL,    prior_tx   REAL,    prior_ty   REAL,    prior_tz   REAL,"
    "CONSTRAINT image_id_check CHECK(image_id >= 0 and image_id < "
    "2147483647),FOREIGN KEY(camera_id) REFERENCES cameras(camera_id))",
    "CREATE TABLE keypoints   (image_id  INTEGER  PRIMARY KEY  NOT NULL,"
    "    rows      INTEGER               NOT NULL,    cols      INTEGER"
    "               NOT NULL,    data      BLOB,FOREIGN KEY(image_id) "
    "REFERENCES images(image_id) ON DELETE CASCADE)",
    "CREATE TABLE descriptors   (image_id  INTEGER  PRIMARY KEY  NOT NULL,"
    "    rows      INTEGER               NOT NULL,    cols      INTEGER"
    "               NOT NULL,    data      BLOB,FOREIGN KEY(image_id) "
    "REFERENCES images(image_id) ON DELETE CASCADE)",
    "CREATE TABLE matches   (pair_id  INTEGER  PRIMARY KEY  NOT NULL,"
    "    rows     INTEGER               NOT NULL,    cols     INTEGER"
    "               NOT NULL,    data     BLOB)",
    "CREATE TABLE two_view_geometries   (pair_id  INTEGER  PRIMARY KEY  NOT "
    "NULL,    rows     INTEGER               NOT NULL,    cols     INTEGER"
    "               NOT NULL,    data     BLOB,    config   INTEGER"
    "               NOT NULL,    F        BLOB,    E        BLOB,    H"
    "        BLOB,    qvec     BLOB,    tvec     BLOB)",
    "CREATE UNIQUE INDEX index_name ON images(name)",
]
TABLES = ["cameras", "images", "keypoints", "descriptors", "matches",
          "two_view_geometries"]

# COLMAP 3.8 camera models: id -> (name, number of params).
CAMERA_MODELS = {0: ("SIMPLE_PINHOLE", 3), 1: ("PINHOLE", 4),
                 2: ("SIMPLE_RADIAL", 4), 3: ("RADIAL", 5), 4: ("OPENCV", 8),
                 5: ("OPENCV_FISHEYE", 8), 6: ("FULL_OPENCV", 12),
                 7: ("FOV", 5), 8: ("SIMPLE_RADIAL_FISHEYE", 4),
                 9: ("RADIAL_FISHEYE", 5), 10: ("THIN_PRISM_FISHEYE", 12)}


def pair_id(id1, id2):
    if id1 > id2:
        id1, id2 = id2, id1
    return id1 * PAIR_ID_FACTOR + id2


def split_pair_id(pid):
    return pid // PAIR_ID_FACTOR, pid % PAIR_ID_FACTOR


def doubles(*values):
    return struct.pack("<%dd" % len(values), *values)


def u32_pairs(pairs):
    return b"".join(struct.pack("<II", a, b) for a, b in pairs)


def unpack_u32_pairs(blob):
    values = struct.unpack("<%dI" % (len(blob) // 4), blob)
    return list(zip(values[0::2], values[1::2]))


class Content:
    """The rows of one small database."""

    def __init__(self):
        self.schema = list(COLMAP_38_SCHEMA)
        self.cameras = []    # (camera_id, model, width, height, params, prior)
        self.images = []     # (image_id, name, camera_id, qw..tz)
        self.keypoints = {}  # image_id -> list of (x, y, a11, a12, a21, a22)
        self.matches = []    # (pair_id, [(idx1, idx2)])
        self.geometries = []  # (pair_id, [(idx1, idx2)], config, F, E, H,
        #                       qvec, tvec)


def read_dataset(path):
    """4 well-connected images of a real database, trimmed."""
    src = sqlite3.connect("file:%s?mode=ro&immutable=1" % path, uri=True)
    content = Content()
    schema = [row[0] for row in src.execute(
        "SELECT sql FROM sqlite_master WHERE sql IS NOT NULL AND "
        "name != 'sqlite_sequence' ORDER BY rowid")]
    if schema:
        content.schema = schema
    # Greedy choice: the pair with most inliers, then the image with most
    # verified pairs to those chosen (ties: most inliers).
    edges = {}
    for pid, rows in src.execute(
            "SELECT pair_id, rows FROM two_view_geometries "
            "WHERE rows >= 30 AND config IN (2, 3, 4, 5, 6)"):
        edges[split_pair_id(pid)] = rows
    if not edges:
        return None
    chosen = list(max(edges, key=edges.get))
    neighbours = {}
    for (a, b), rows in edges.items():
        neighbours.setdefault(a, {})[b] = rows
        neighbours.setdefault(b, {})[a] = rows
    while len(chosen) < NUM_IMAGES:
        best = None
        for candidate in neighbours:
            if candidate in chosen:
                continue
            links = [neighbours[candidate].get(c) for c in chosen]
            links = [rows for rows in links if rows]
            score = (len(links), sum(links))
            if best is None or score > best[0]:
                best = (score, candidate)
        if best is None or best[0][0] == 0:
            break
        chosen.append(best[1])
    chosen.sort()

    pair_ids = [pair_id(a, b) for i, a in enumerate(chosen)
                for b in chosen[i + 1:]]
    # The first MATCHES_PER_PAIR inliers of every pair, and the keypoints
    # they use; every other keypoint goes.
    used = {image_id: set() for image_id in chosen}
    geometries = []
    for pid in pair_ids:
        row = src.execute(
            "SELECT rows, cols, data, config, F, E, H, qvec, tvec "
            "FROM two_view_geometries WHERE pair_id = ?", (pid,)).fetchone()
        if row is None or row[0] == 0 or row[2] is None:
            continue
        id1, id2 = split_pair_id(pid)
        inliers = unpack_u32_pairs(row[2])[:MATCHES_PER_PAIR]
        for idx1, idx2 in inliers:
            used[id1].add(idx1)
            used[id2].add(idx2)
        geometries.append((pid, inliers) + tuple(row[3:]))
    remap = {}
    for image_id in chosen:
        krow = src.execute(
            "SELECT rows, cols, data FROM keypoints WHERE image_id = ?",
            (image_id,)).fetchone()
        kept = sorted(used[image_id])
        remap[image_id] = {old: new for new, old in enumerate(kept)}
        points = []
        if krow is not None and krow[2] is not None:
            rows, cols, data = krow
            values = struct.unpack("<%df" % (rows * cols), data)
            for old in kept:
                point = list(values[old * cols:(old + 1) * cols])
                if cols == 2:
                    point += [1.0, 0.0, 0.0, 1.0]
                elif cols == 4:
                    scale, orientation = point[2], point[3]
                    point = point[:2] + [
                        scale * math.cos(orientation),
                        -scale * math.sin(orientation),
                        scale * math.sin(orientation),
                        scale * math.cos(orientation)]
                points.append(tuple(point))
        content.keypoints[image_id] = points
    for pid, inliers, *rest in geometries:
        id1, id2 = split_pair_id(pid)
        mapped = [(remap[id1][a], remap[id2][b]) for a, b in inliers]
        content.geometries.append((pid, mapped) + tuple(rest))
    for pid in pair_ids:
        row = src.execute("SELECT data FROM matches WHERE pair_id = ?",
                          (pid,)).fetchone()
        if row is None or row[0] is None:
            continue
        id1, id2 = split_pair_id(pid)
        raw = [(remap[id1][a], remap[id2][b])
               for a, b in unpack_u32_pairs(row[0])
               if a in remap[id1] and b in remap[id2]]
        content.matches.append((pid, raw[:RAW_MATCHES_PER_PAIR]))
    placeholders = ",".join("?" * len(chosen))
    content.images = [tuple(row) for row in src.execute(
        "SELECT image_id, name, camera_id, prior_qw, prior_qx, prior_qy, "
        "prior_qz, prior_tx, prior_ty, prior_tz FROM images "
        "WHERE image_id IN (%s) ORDER BY image_id" % placeholders, chosen)]
    camera_ids = sorted({row[2] for row in content.images})
    content.cameras = [tuple(row) for row in src.execute(
        "SELECT camera_id, model, width, height, params, prior_focal_length "
        "FROM cameras WHERE camera_id IN (%s)" %
        ",".join("?" * len(camera_ids)), camera_ids)]
    src.close()
    return content


def generated_content():
    """A tiny made-up scene: 4 images, 60 keypoints each, 6 pairs."""
    content = Content()
    content.cameras = [(1, 2, 640, 480, doubles(500, 320, 240, 0.01), 0),
                       (2, 1, 800, 600, doubles(700, 710, 400, 300), 1)]
    for i in range(1, 5):
        priors = (1.0, 0.0, 0.0, 0.0, float(i), 0.0, 0.0) if i == 2 else \
            (None,) * 7
        content.images.append((i, "img%d.jpg" % i, 1 if i != 2 else 2) +
                              priors)
        content.keypoints[i] = [(10.0 * i + 7.5 * k, 5.0 * i + 3.25 * k,
                                 1.5, 0.0, 0.0, 1.5) for k in range(60)]
    config = [2, 3, 4, 5, 6, 7]
    for n, (a, b) in enumerate([(1, 2), (1, 3), (1, 4), (2, 3), (2, 4),
                                (3, 4)]):
        inliers = [(k, (k + n) % 60) for k in range(20 + 4 * n)]
        matrix = doubles(*[0.1 * (k + n) for k in range(9)])
        content.matches.append((pair_id(a, b), inliers + [(59, 0)]))
        content.geometries.append(
            (pair_id(a, b), inliers, config[n], matrix, matrix, matrix,
             doubles(1, 0, 0, 0), doubles(1, 0, 0)))
    return content


def keypoint_blob(points, cols=6):
    return b"".join(struct.pack("<%df" % cols, *point[:cols])
                    for point in points)


def write_database(path, content, page_size=1024, encoding=None,
                   journal_mode=None, keypoint_cols=6, damage=None):
    """Writes `content` to `path`, applies `damage(db, content)`, vacuums."""
    if os.path.exists(path):
        os.remove(path)
    db = sqlite3.connect(path)
    db.execute("PRAGMA page_size = %d" % page_size)
    if encoding:
        db.execute("PRAGMA encoding = '%s'" % encoding)
    for sql in content.schema:
        db.execute(sql)
    db.executemany("INSERT INTO cameras VALUES (?, ?, ?, ?, ?, ?)",
                   content.cameras)
    db.executemany("INSERT INTO images VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                   content.images)
    for image_id, points in sorted(content.keypoints.items()):
        db.execute("INSERT INTO keypoints VALUES (?, ?, ?, ?)",
                   (image_id, len(points), keypoint_cols,
                    keypoint_blob(points, keypoint_cols)))
    for pid, pairs in content.matches:
        db.execute("INSERT INTO matches VALUES (?, ?, 2, ?)",
                   (pid, len(pairs), u32_pairs(pairs)))
    for pid, pairs, config, f, e, h, qvec, tvec in content.geometries:
        db.execute(
            "INSERT INTO two_view_geometries VALUES (?, ?, 2, ?, ?, ?, ?, ?, "
            "?, ?)", (pid, len(pairs), u32_pairs(pairs), config, f, e, h,
                      qvec, tvec))
    db.commit()
    if damage:
        damage(db, content)
        db.commit()
    db.execute("VACUUM")
    if journal_mode:
        db.execute("PRAGMA journal_mode = %s" % journal_mode)
    db.close()
    for suffix in ("-wal", "-shm", "-journal"):
        if os.path.exists(path + suffix):
            os.remove(path + suffix)


# Damage kinds: name -> function(db, content). `first`/`second` image ids and
# the first pair id come from the content, so that every variant hits rows
# that exist.
def sql(*statements):
    return lambda db, content: db.executescript(";".join(statements) + ";")


def without_primary_key(table, extra):
    """The table rebuilt without constraints, then `extra` (SQL)."""
    return ("CREATE TABLE {t}_copy AS SELECT * FROM {t}; DROP TABLE {t}; "
            "ALTER TABLE {t}_copy RENAME TO {t}; ".format(t=table) + extra)


def damages(content):
    ids = [row[0] for row in content.images]
    first, second = ids[0], ids[1]
    pid = content.geometries[0][0]
    cam = content.cameras[0][0]
    nan, inf = float("nan"), float("inf")

    def set_blob(sql_text, blob):
        return lambda db, c: db.execute(sql_text, (blob,))

    def nonfinite_keypoints(db, c):
        points = [list(p) for p in c.keypoints[first]]
        for k, value in ((0, nan), (3, inf), (5, -inf)):
            if k < len(points):
                points[k][k % 2] = value
        db.execute("UPDATE keypoints SET data = ? WHERE image_id = ?",
                   (keypoint_blob(points), first))
        db.execute("UPDATE keypoints SET data = ? WHERE image_id = ?",
                   (keypoint_blob([(nan,) * 6] * len(c.keypoints[second])),
                    second))

    def out_of_range_matches(db, c):
        n = len(c.keypoints[split_pair_id(pid)[0]])
        pairs = list(c.geometries[0][1])
        pairs[:4] = [(n, 0), (0, n + 7), (0xFFFFFFFF, 1), (2, 0x80000000)]
        db.execute("UPDATE two_view_geometries SET data = ? WHERE "
                   "pair_id = ?", (u32_pairs(pairs), pid))

    def camera_params(*params):
        return set_blob("UPDATE cameras SET params = ? WHERE camera_id = %d"
                        % cam, doubles(*params))

    def camera_models(db, c):
        # Every COLMAP 3.8 model once, one camera per image.
        for n, image_id in enumerate(ids):
            model = [0, 1, 3, 4, 5, 6, 7, 8, 9, 10][n % 10]
            count = CAMERA_MODELS[model][1]
            params = [600.0, 320.0, 240.0] if count == 3 else \
                [600.0, 610.0, 320.0, 240.0] + [0.001] * (count - 4) \
                if model in (1, 4, 5, 6, 10) else \
                [600.0, 320.0, 240.0] + [0.001] * (count - 3)
            db.execute("INSERT INTO cameras VALUES (?, ?, 640, 480, ?, ?)",
                       (100 + n, model, doubles(*params), n % 2))
            db.execute("UPDATE images SET camera_id = ? WHERE image_id = ?",
                       (100 + n, image_id))

    matrix = doubles(*[1.0] * 8 + [inf])
    return {
        # Keypoints.
        "keypoints_nonfinite": nonfinite_keypoints,
        "keypoints_short_blob": sql(
            "UPDATE keypoints SET data = substr(data, 1, length(data) - 4) "
            "WHERE image_id = %d" % first),
        "keypoints_cols_3": sql("UPDATE keypoints SET cols = 3"),
        "keypoints_null_blob": sql(
            "UPDATE keypoints SET data = NULL WHERE image_id = %d" % first),
        "keypoints_counts": sql(
            "UPDATE keypoints SET rows = -1 WHERE image_id = %d" % first,
            "UPDATE keypoints SET rows = 4294967296 WHERE image_id = %d"
            % second,
            "INSERT INTO keypoints VALUES (77, 0, 6, NULL)"),
        "keypoints_empty": sql("UPDATE keypoints SET rows = 0, data = NULL"),
        "keypoints_repeated": sql(without_primary_key(
            "keypoints",
            "INSERT INTO keypoints SELECT * FROM keypoints WHERE image_id = "
            "%d; INSERT INTO keypoints VALUES (%d, 3, 2, zeroblob(24))"
            % (second, first))),
        # Verified matches.
        "matches_out_of_range": out_of_range_matches,
        "matches_short_blob": sql(
            "UPDATE two_view_geometries SET data = substr(data, 1, "
            "length(data) - 4) WHERE pair_id = %d" % pid),
        "matches_count_2_31": sql(
            "UPDATE two_view_geometries SET rows = 2147483648 "
            "WHERE pair_id = %d" % pid),
        "matches_count_2_62": sql(
            "UPDATE two_view_geometries SET rows = 4611686018427387904, "
            "data = zeroblob(8) WHERE pair_id = %d" % pid),
        "matches_raw_counts": sql(
            "UPDATE matches SET rows = -5 WHERE pair_id = %d" % pid,
            "UPDATE matches SET rows = 9223372036854775807 WHERE pair_id "
            "!= %d" % pid),
        "matches_cols_3": sql("UPDATE two_view_geometries SET cols = 3"),
        "matches_null_blob": sql(
            "UPDATE two_view_geometries SET data = NULL WHERE pair_id = %d"
            % pid),
        "pairs_unknown_images": sql(*(
            "INSERT INTO two_view_geometries SELECT {}, rows, cols, data, "
            "config, F, E, H, qvec, tvec FROM two_view_geometries WHERE "
            "pair_id = {}".format(p, pid)
            for p in (pair_id(first, 99), first * PAIR_ID_FACTOR + first,
                      -pid, 9223372036854775807,
                      pair_id(second, first) + PAIR_ID_FACTOR))),
        "pairs_repeated": sql(without_primary_key(
            "two_view_geometries",
            "INSERT INTO two_view_geometries SELECT * FROM "
            "two_view_geometries WHERE pair_id = %d; UPDATE "
            "two_view_geometries SET config = 4 WHERE rowid = (SELECT "
            "max(rowid) FROM two_view_geometries)" % pid)),
        "pairs_configs": sql(
            "UPDATE two_view_geometries SET config = CASE pair_id % 7 "
            "WHEN 0 THEN -1 WHEN 1 THEN 8 WHEN 2 THEN 9 WHEN 3 THEN 42 "
            "WHEN 4 THEN 7 WHEN 5 THEN 1 ELSE 0 END"),
        "pairs_all_config_42": sql(
            "UPDATE two_view_geometries SET config = 42"),
        "pairs_null_matrices": sql(
            "UPDATE two_view_geometries SET F = NULL, E = zeroblob(0), "
            "H = NULL WHERE pair_id = %d" % pid),
        "pairs_nonfinite_matrix": set_blob(
            "UPDATE two_view_geometries SET H = ?", matrix),
        "pairs_matrix_size": sql(
            "UPDATE two_view_geometries SET E = zeroblob(64) "
            "WHERE pair_id = %d" % pid),
        "pairs_too_few": sql("UPDATE two_view_geometries SET rows = 14, "
                             "data = substr(data, 1, 112)"),
        # Cameras and images.
        "camera_nan": camera_params(nan, 320, 240, 0),
        "camera_inf": camera_params(500, inf, -inf, 0),
        "camera_negative_focal": camera_params(-5, 320, 240, 0),
        "camera_zero_focal": camera_params(0, 320, 240, 0),
        "camera_principal_point": camera_params(500, 1e7, 240, 0),
        "camera_params_size": sql(
            "UPDATE cameras SET params = zeroblob(24)"),
        "camera_params_null": sql("UPDATE cameras SET params = NULL"),
        "camera_model_42": sql("UPDATE cameras SET model = 42"),
        "camera_model_negative": sql("UPDATE cameras SET model = -1"),
        "camera_model_11": sql("UPDATE cameras SET model = 11"),
        "camera_size": sql("UPDATE cameras SET width = 0, height = -480"),
        "camera_id_huge": sql(
            "UPDATE cameras SET camera_id = 4294967295 WHERE camera_id = %d"
            % cam,
            "UPDATE images SET camera_id = 4294967295 WHERE camera_id = %d"
            % cam),
        "camera_models": camera_models,
        "cameras_repeated": sql(without_primary_key(
            "cameras", "INSERT INTO cameras SELECT camera_id, 0, 1, 1, "
            "zeroblob(24), 0 FROM cameras")),
        "image_unknown_camera": sql(
            "UPDATE images SET camera_id = 99 WHERE image_id = %d" % second),
        "image_ids": sql(without_primary_key(
            "images", "UPDATE images SET image_id = -3 WHERE image_id = %d; "
            "INSERT INTO images (image_id, name, camera_id) VALUES "
            "(2147483647, 'huge', %d)" % (second, cam))),
        "images_repeated": sql(without_primary_key(
            "images", "INSERT INTO images (image_id, name, camera_id) "
            "SELECT image_id, name || '_again', camera_id FROM images")),
        "images_priors_and_names": sql(without_primary_key(
            "images", "UPDATE images SET prior_qw = 'text', prior_qx = "
            "x'00', prior_qy = 1e308, prior_tz = 7 WHERE image_id = %d; "
            "UPDATE images SET name = NULL WHERE image_id = %d"
            % (first, second))),
        "images_one": sql("DELETE FROM images WHERE image_id != %d" % first),
        "images_none": sql("DELETE FROM images"),
        # Column types SQLite lets through despite the declared ones.
        "types_text_and_real": sql(
            "UPDATE keypoints SET rows = CAST(rows AS TEXT) || '.0'",
            "UPDATE two_view_geometries SET rows = rows + 0.5, "
            "config = CAST(config AS TEXT)",
            "UPDATE cameras SET params = CAST(params AS TEXT)"),
        # Tables and schema.
        "missing_cameras": sql("DROP TABLE cameras"),
        "missing_images": sql("DROP TABLE images"),
        "missing_keypoints": sql("DROP TABLE keypoints"),
        "missing_matches": sql("DROP TABLE matches"),
        "missing_two_view_geometries": sql("DROP TABLE two_view_geometries"),
        "pre_3_5_schema": sql(
            "ALTER TABLE two_view_geometries RENAME TO inlier_matches"),
        "missing_column": sql(
            "CREATE TABLE images_copy AS SELECT image_id, name, camera_id "
            "FROM images; DROP TABLE images; "
            "ALTER TABLE images_copy RENAME TO images"),
        "view_instead_of_table": sql(
            "ALTER TABLE matches RENAME TO matches_table; CREATE VIEW "
            "matches AS SELECT * FROM matches_table"),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir")
    parser.add_argument(
        "--datasets",
        default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                             "..", "..", "..", "shared", "datasets"))
    args = parser.parse_args()

    if os.path.isdir(args.out_dir):
        shutil.rmtree(args.out_dir)
    os.makedirs(args.out_dir)
    out = lambda name: os.path.join(args.out_dir, name)

    bases = []
    if os.path.isdir(args.datasets):
        for name in sorted(os.listdir(args.datasets)):
            path = os.path.join(args.datasets, name, "database.db")
            if not os.path.isfile(path):
                continue
            try:
                content = read_dataset(path)
            except sqlite3.Error as error:
                print("make_seed_corpus: skipping %s (%s)" % (path, error),
                      file=sys.stderr)
                continue
            if content is not None:
                bases.append((name, content))
    if not bases:
        print("make_seed_corpus: no dataset under %s, using a generated "
              "database" % args.datasets, file=sys.stderr)
        bases.append(("generated", generated_content()))
    for name, content in bases:
        write_database(out("valid_%s.db" % name), content)

    # Variants of the smallest base.
    base_name, base = bases[0]
    write_database(out("valid_generated_small.db"), generated_content())
    write_database(out("keypoints_cols_2.db"), base, keypoint_cols=2)
    write_database(out("keypoints_cols_4.db"), base, keypoint_cols=4)
    write_database(out("journal_rollback_4k_pages.db"), base, page_size=4096,
                   journal_mode="DELETE")
    write_database(out("journal_wal.db"), base, journal_mode="WAL")
    write_database(out("encoding_utf16.db"), base, encoding="UTF-16le")
    for name, damage in damages(base).items():
        write_database(out(name + ".db"), base, damage=damage)

    # Files that are not (whole) databases.
    with open(out("valid_%s.db" % base_name), "rb") as f:
        valid = f.read()
    files = {
        "file_empty.db": b"",
        "file_not_sqlite.db": b"this is not a database, just some text "
                              b"that is long enough to be a header\n",
        "file_header_only.db": valid[:100],
        "file_truncated_half.db": valid[:len(valid) // 2],
        "file_truncated_page.db": valid[:1024 + 17],
    }
    for name, data in files.items():
        with open(out(name), "wb") as f:
            f.write(data)

    sizes = [os.path.getsize(out(n)) for n in os.listdir(args.out_dir)]
    print("make_seed_corpus: %d files in %s (largest %d bytes, from %s)" %
          (len(sizes), args.out_dir, max(sizes),
           ", ".join(name for name, _ in bases)))


if __name__ == "__main__":
    main()
