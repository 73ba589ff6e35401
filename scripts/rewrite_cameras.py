#!/usr/bin/env python3
"""Writes a copy of a COLMAP 3.8 database whose cameras are set up the way a
user's project often is, keeping every keypoint, match and two-view geometry:
one camera per image (what `colmap feature_extractor` gives by default) or one
shared camera, with any COLMAP camera model, and either no focal prior (focal
1.2 x the larger image side, as the extractor sets it without EXIF) or an
EXIF-like prior (the ground-truth focal off by up to --exif_error, flag set).

The input database is never opened, only copied byte for byte (refused when
a -wal file beside it holds data) to --output_path, which must not exist.
In the copy the cameras table is replaced and every image's camera_id set:

  --camera_mode per_image   camera i+1 for the i-th image by image_id
  --camera_mode shared      camera 1 for every image

Parameters of each new camera, as COLMAP 3.8's feature extractor writes them
(Camera::InitializeWithName): every focal parameter f, the principal point at
(width / 2, height / 2), every distortion parameter 0. The image size is
the one of the image's camera in the input. f is

  --focal guess   1.2 x max(width, height), prior_focal_length = 0
  --focal exif    the ground-truth focal (mean of fx, fy of the image's
                  camera in --gt_path, matched by image name) times
                  (1 + e), e uniform in [-exif_error, exif_error] drawn once
                  per distinct ground-truth focal from --seed (one physical
                  camera writes one EXIF focal, and ground truths often
                  repeat one camera per image), prior_focal_length = 1

Example (one SIMPLE_RADIAL camera per image, no prior: the most common
project):
    scripts/rewrite_cameras.py \\
        --database_path ../shared/datasets/templeRing/database.db \\
        --output_path /tmp/templeRing_per_image.db --camera_mode per_image

Check the script's own logic (no dataset needed):
    python3 scripts/rewrite_cameras_test.py

Only the Python standard library is used.
"""

import argparse
import os
import random
import shutil
import sqlite3
import struct
import sys

# COLMAP 3.8's camera models: name -> (model_id, number of parameters,
# indices of the focal parameters). The principal point follows the focal
# parameters; the rest are distortion parameters.
CAMERA_MODELS = {
    "SIMPLE_PINHOLE": (0, 3, (0,)),
    "PINHOLE": (1, 4, (0, 1)),
    "SIMPLE_RADIAL": (2, 4, (0,)),
    "RADIAL": (3, 5, (0,)),
    "OPENCV": (4, 8, (0, 1)),
    "OPENCV_FISHEYE": (5, 8, (0, 1)),
    "FULL_OPENCV": (6, 12, (0, 1)),
    "FOV": (7, 5, (0, 1)),
    "SIMPLE_RADIAL_FISHEYE": (8, 4, (0,)),
    "RADIAL_FISHEYE": (9, 5, (0,)),
    "THIN_PRISM_FISHEYE": (10, 12, (0, 1)),
}
MODEL_NAMES_BY_ID = {model_id: name for name, (model_id, _, _) in
                     CAMERA_MODELS.items()}

# COLMAP's ImageReaderOptions::default_focal_length_factor.
DEFAULT_FOCAL_LENGTH_FACTOR = 1.2


class RewriteError(Exception):
    pass


def camera_params(model_name, focal_px, width, height):
    """The parameter vector COLMAP 3.8's Camera::InitializeWithName gives."""
    model_id, num_params, focal_idxs = CAMERA_MODELS[model_name]
    params = [0.0] * num_params
    for idx in focal_idxs:
        params[idx] = float(focal_px)
    pp_idx = len(focal_idxs)
    params[pp_idx] = width / 2.0
    params[pp_idx + 1] = height / 2.0
    if model_name == "FOV":
        params[4] = 1e-2  # COLMAP's FOV model starts omega away from zero.
    return params


def read_gt_focals(gt_path):
    """{image name: mean focal (px)} and {image name: gt camera id} from a
    COLMAP text model (cameras.txt, images.txt)."""
    focals_by_camera = {}
    with open(os.path.join(gt_path, "cameras.txt")) as f:
        for line in f:
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            camera_id, model = int(fields[0]), fields[1]
            params = [float(v) for v in fields[4:]]
            if model not in CAMERA_MODELS:
                raise RewriteError(f"{gt_path}: unknown camera model {model}")
            focal_idxs = CAMERA_MODELS[model][2]
            focals_by_camera[camera_id] = sum(
                params[i] for i in focal_idxs) / len(focal_idxs)
    focals, gt_camera_ids = {}, {}
    with open(os.path.join(gt_path, "images.txt")) as f:
        pose_line = True
        for line in f:
            if line.startswith("#"):
                continue
            if pose_line:
                fields = line.split()
                if len(fields) >= 10:
                    camera_id, name = int(fields[8]), " ".join(fields[9:])
                    if camera_id not in focals_by_camera:
                        raise RewriteError(
                            f"{gt_path}: image {name} has unknown camera "
                            f"{camera_id}")
                    focals[name] = focals_by_camera[camera_id]
                    gt_camera_ids[name] = camera_id
            pose_line = not pose_line
    return focals, gt_camera_ids


def copy_database(database_path, output_path):
    if not os.path.isfile(database_path):
        raise RewriteError(f"no database at {database_path}")
    if os.path.exists(output_path):
        raise RewriteError(f"{output_path} exists; refusing to overwrite it")
    wal = database_path + "-wal"
    if os.path.isfile(wal) and os.path.getsize(wal) > 0:
        raise RewriteError(
            f"{wal} holds data not yet in {database_path}; open and close the "
            "database with COLMAP first")
    tmp_path = output_path + ".tmp"
    shutil.copyfile(database_path, tmp_path)
    return tmp_path


def rewrite(args):
    model_name = args.camera_model
    if model_name not in CAMERA_MODELS:
        raise RewriteError(f"unknown camera model {model_name}; one of "
                           + ", ".join(CAMERA_MODELS))
    gt_focals, gt_camera_ids = {}, {}
    if args.focal == "exif":
        if not args.gt_path:
            raise RewriteError("--focal exif needs --gt_path")
        gt_focals, gt_camera_ids = read_gt_focals(args.gt_path)

    tmp_path = copy_database(args.database_path, args.output_path)
    try:
        connection = sqlite3.connect(tmp_path)
        with connection:
            cameras = {
                camera_id: (width, height)
                for camera_id, width, height in connection.execute(
                    "SELECT camera_id, width, height FROM cameras")
            }
            images = connection.execute(
                "SELECT image_id, name, camera_id FROM images "
                "ORDER BY image_id").fetchall()
            if not images:
                raise RewriteError(f"{args.database_path} has no images")
            rng = random.Random(args.seed)
            exif_factor_by_gt_camera = {}

            def focal_for(name, width, height):
                if args.focal == "guess":
                    return DEFAULT_FOCAL_LENGTH_FACTOR * max(width, height)
                if name not in gt_focals:
                    raise RewriteError(
                        f"image {name} is not in the ground truth")
                physical = round(gt_focals[name], 6)
                if physical not in exif_factor_by_gt_camera:
                    exif_factor_by_gt_camera[physical] = 1 + rng.uniform(
                        -args.exif_error, args.exif_error)
                return gt_focals[name] * exif_factor_by_gt_camera[physical]

            new_cameras = []  # (camera_id, width, height, focal)
            image_camera = []  # (camera_id, image_id)
            for index, (image_id, name, camera_id) in enumerate(images):
                if camera_id not in cameras:
                    raise RewriteError(
                        f"image {name} refers to missing camera {camera_id}")
                width, height = cameras[camera_id]
                if args.camera_mode == "per_image":
                    new_id = index + 1
                    new_cameras.append(
                        (new_id, width, height, focal_for(name, width, height)))
                else:
                    new_id = 1
                    if not new_cameras:
                        new_cameras.append((1, width, height,
                                            focal_for(name, width, height)))
                    elif (width, height) != new_cameras[0][1:3]:
                        raise RewriteError(
                            "--camera_mode shared needs images of one size")
                image_camera.append((new_id, image_id))

            connection.execute("DELETE FROM cameras")
            model_id = CAMERA_MODELS[model_name][0]
            prior = 1 if args.focal == "exif" else 0
            for camera_id, width, height, focal in new_cameras:
                params = camera_params(model_name, focal, width, height)
                connection.execute(
                    "INSERT INTO cameras (camera_id, model, width, height, "
                    "params, prior_focal_length) VALUES (?, ?, ?, ?, ?, ?)",
                    (camera_id, model_id, width, height,
                     struct.pack(f"<{len(params)}d", *params), prior))
            connection.executemany(
                "UPDATE images SET camera_id = ? WHERE image_id = ?",
                image_camera)
        connection.close()
        os.replace(tmp_path, args.output_path)
    except BaseException:
        if os.path.exists(tmp_path):
            os.remove(tmp_path)
        raise
    return len(new_cameras), len(images)


def parse_args(argv):
    parser = argparse.ArgumentParser(
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--database_path", required=True)
    parser.add_argument("--output_path", required=True)
    parser.add_argument("--camera_mode", choices=("per_image", "shared"),
                        default="per_image")
    parser.add_argument("--camera_model", default="SIMPLE_RADIAL",
                        help="COLMAP camera model name")
    parser.add_argument("--focal", choices=("guess", "exif"), default="guess")
    parser.add_argument("--gt_path", help="ground-truth text model "
                        "(cameras.txt, images.txt), for --focal exif")
    parser.add_argument("--exif_error", type=float, default=0.02,
                        help="relative error of the EXIF-like focal, at most")
    parser.add_argument("--seed", type=int, default=0)
    return parser.parse_args(argv)


def main(argv):
    args = parse_args(argv)
    try:
        num_cameras, num_images = rewrite(args)
    except (RewriteError, sqlite3.Error, OSError) as error:
        print(f"rewrite_cameras: error: {error}", file=sys.stderr)
        return 1
    print(f"rewrite_cameras: {args.output_path}: {num_cameras} "
          f"{args.camera_model} camera(s) for {num_images} images, focal "
          f"{args.focal}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
