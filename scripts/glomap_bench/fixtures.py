"""Made-up runs and report metadata shared by the package's tests (no colmap
needed)."""

from glomap_bench import parse, scale_runs

# The sizes of the made-up scale runs.
SIZES = [1000, 2000, 5000, 10000]


def dataset_run(mapper, seed, registered, auc3, wall, beyond=0, names=None,
                status="ok", pos=0.01):
    """A run record of scripts/benchmark.py on dataset "d" of 10 images."""
    ev = {"images": 10, "registered": registered, "auc@1": 50.0,
          "auc@3": auc3, "auc@5": 90.0, "auc@10": 95.0,
          "pos_err_mean": pos}
    if beyond is not None:
        ev.update(cameras_beyond=beyond, cameras_beyond_fraction=0.05)
    record = {"dataset": "d", "mapper": mapper, "status": status,
              "wall_time_s": wall, "evaluation": ev,
              "replaced_images": 1, "left_out_images": 0,
              "stages": [["relative_poses", wall / 2]]}
    if seed is not None:
        record["seed"] = seed
    if names is not None:
        record["image_names"] = names
    return record


def readme_figures():
    """parse_reference() of a dataset README with both reference mappers."""
    return {"incremental": {"auc@3": 90.0, "registered": [10, 10],
                            "wall_time_s": 20.0},
            "upstream": {"auc@3": 91.0, "registered": [10, 10]}}


def stock_run():
    """The stock mapper's run, 8 of 10 images registered, in 100 s."""
    return dataset_run("incremental", None, 8, 70.2, 100.0,
                       names=["1", "2", "3", "4", "5", "6", "7", "8"])


def seed_runs():
    """Three runs of ours with seeds 0, 1, 2 (the third with 2 cameras
    beyond)."""
    runs = [dataset_run("global", s, 10, a, w) for s, a, w in
            [(0, 80.0, 3.0), (1, 82.0, 5.0), (2, 81.0, 4.0)]]
    runs[2]["evaluation"]["cameras_beyond"] = 2
    return runs


def repeated_runs():
    """Six runs of ours: seeds 0 and 1, three repeats each; seed 0 takes
    3, 1, 2 s, seed 1 6, 2, 4 s, AUC@3 80, 82, 81 per repeat."""
    repeated = []
    for repeat, (wall0, wall1, auc) in enumerate(
            [(3.0, 6.0, 80.0), (1.0, 2.0, 82.0), (2.0, 4.0, 81.0)]):
        for seed, wall in ((0, wall0), (1, wall1)):
            r = dataset_run("global", seed, 10, auc, wall)
            r["repeat"] = repeat
            r["model_path"] = "m%d%d" % (seed, repeat)
            repeated.append(r)
    return repeated


def benchmark_meta():
    """results.json's "meta" of a made-up run of scripts/benchmark.py."""
    return {"command": "python3 scripts/benchmark.py --repeats 2 "
                       "--readme '/tmp/a b/README.md'",
            "cwd": "/work/main", "date": "today", "seeds": [0, 1, 2],
            "machine": {"cpu": "Test CPU @ 2.0GHz", "cores": 2,
                        "memory_gib": 23.54, "kernel": "Linux 6.1.0"},
            "colmap": {"path": "/r/build/bin/colmap", "build_type": "Release",
                       "source": "/r", "commit": "abc1234+dirty"},
            "reference_colmap": {"path": "/u/build/bin/colmap",
                                 "build_type": "unknown", "source": None,
                                 "commit": None},
            "repeats": {"datasets": 3, "synthetic scenes": 1}}


def scale_record(layout, n, seed=0, status="ok"):
    """A run record of scripts/benchmark_scale.py: time ~ n^1 except
    rotation averaging ~ n^1.5 and camera clustering ~ n^1.4 (negligible);
    memory ~ n^0.5. A failed run stopped in rotation averaging."""
    stages = [["database", 1e-3 * n], ["rotation_averaging",
                                       1e-5 * n ** 1.5],
              ["camera_clustering", 1e-7 * n ** 1.4]]
    r = {"layout": layout, "label": scale_runs.LAYOUT_LABELS[layout],
         "images": n,
         "seed": seed, "status": status,
         "scene": {"wall_s": 0.01 * n, "peak_rss_mb": 0.1 * n}}
    if status != "ok":
        # Stopped in the second stage.
        r.update(stages=stages[:1], wall_time_s=60.0, peak_rss_mb=250.0,
                 stage_peak_rss_mb={"database": 200.0,
                                    "rotation_averaging": 250.0},
                 unfinished_stage="rotation_averaging")
        return r
    r.update(stages=stages, wall_time_s=sum(s for _, s in stages) + 0.5,
             peak_rss_mb=3 * n ** 0.5,
             stage_peak_rss_mb={"database": 2 * n ** 0.5,
                                "rotation_averaging": 3 * n ** 0.5,
                                parse.OTHER: 1.0 * n ** 0.5},
             evaluation={"images": n, "registered": n, "auc@1": 50.0,
                         "auc@3": 80.0, "auc@5": 90.0,
                         "rot_err_median_deg": 0.0123},
             evaluation_s=1.0)
    return r


def scale_records():
    """Both layouts at every size; the street's largest run timed out."""
    records = [scale_record(layout, n) for n in SIZES
               for layout in ("grid", "forward")]
    records[-1] = scale_record("forward", 10000,
                               status="timeout after 60 s")
    return records


def scale_meta():
    """results.json's "meta" of a made-up run of
    scripts/benchmark_scale.py."""
    return {"command": "python3 scripts/benchmark_scale.py --sizes 1000",
            "cwd": "/work/main", "date": "today", "seeds": [0],
            "layouts": ["grid", "forward"], "num_threads": -1,
            "mapper_args": [], "sample_interval_s": 0.2,
            "machine": {"cpu": "Test CPU", "cores": 2, "memory_gib": 23.5,
                        "kernel": "Linux 6.1.0"},
            "colmap": {"path": "/r/build/bin/colmap", "build_type": "Release",
                       "source": "/r", "commit": "abc1234"}}
