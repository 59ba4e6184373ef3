"""Localise many videos on a Dask cluster: one task per video, all poses in one
table.

Each video becomes one `dask.distributed` task that runs
`panotrack.localize_video` (panoloc's own pipeline) on a worker. The rows come
back to the client and are joined into one numpy table: a `video` column
followed by the pose CSV's columns (frame, time_s, x, y, theta_rad, status,
n_landmarks, residual, std_x, std_y, std_theta, quality). A video that cannot
be used (missing, corrupt) is reported in the per-video status list with the
library's one-line message, the one panoloc prints after "panoloc: ", and the
other videos' rows are kept.

    python3 dask_localize.py --local-workers 4 --calib C.yaml --map M.yaml --out table.csv VIDEO...
    python3 dask_localize.py --scheduler tcp://HOST:8786 --calib C.yaml --map M.yaml --out table.csv VIDEO...

With --local-workers the script starts a cluster of N single-threaded worker
processes on this machine; with --scheduler it connects to a running
cluster, whose workers need panotrack installed and the videos at the same
paths (a shared file system). The calibration and map are read here and
sent to the workers once. Prints one line per video, as panoloc does, and
exits 1 when any video failed (its rows are absent from the table).
"""
import argparse
import contextlib
import csv
import sys
import warnings

import numpy as np

import panotrack as pt


def localize_one(video, calibration, map, **options):
    """Runs on a worker: localize_video on one input. Returns a status dict
    (`video`, `end`, `frames`, `n_ok`, `n_lost`, `seconds`, `error`,
    `warnings`) with the rows under `rows` (None when the input failed)."""
    status = {"video": str(video), "end": "failed", "frames": 0, "n_ok": 0, "n_lost": 0, "seconds": 0.0,
              "error": "", "warnings": [], "rows": None}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            rows, summary = pt.localize_video(video, calibration, map, return_summary=True, **options)
        except pt.Error as e:  # the library's one-line message
            status["error"] = str(e)
            return status
    status.update(end=summary["end"], frames=summary["frames"], n_ok=summary["n_ok"],
                  n_lost=summary["n_lost"], seconds=summary["seconds"], error=summary["error"],
                  warnings=[str(w.message) for w in caught], rows=rows)
    return status


def table_dtype(videos):
    """The table's dtype: `video` (wide enough for every name) then POSE_DTYPE."""
    width = max([len(str(v)) for v in videos] + [1])
    return np.dtype([("video", f"U{width}")] + [(name, pt.POSE_DTYPE[name]) for name in pt.POSE_DTYPE.names])


def localize_all(client, videos, calibration, map, num_threads=1, **options):
    """Localises every video on the cluster of `client`, one task each.

    calibration and map: objects or paths (read here, sent to the workers
    once). num_threads: threads of each localisation (1: the parallelism is
    across videos; each worker thread runs one video at a time). options:
    localize_video's (method, init, fps, search_px...).

    Returns (table, statuses): a structured array of the rows of every video
    that ran, in the order of `videos` (`video` column first, then
    POSE_DTYPE's), and one status dict per video (see localize_one, without
    `rows`). A failure of one task never loses the others' results.
    """
    if not isinstance(calibration, pt.Calibration):
        calibration = pt.read_calibration(calibration)
    if not isinstance(map, pt.Map):
        map = pt.read_map(map)
    videos = [str(v) for v in videos]
    if __name__ != "__main__":
        # Imported (a notebook, a test): send localize_one by value, so the
        # workers need panotrack but not this file.
        import cloudpickle
        cloudpickle.register_pickle_by_value(sys.modules[__name__])
    # One copy of each per worker instead of one per task.
    calibration_future, map_future = client.scatter([calibration, map], broadcast=True)
    futures = client.map(localize_one, videos, calibration=calibration_future, map=map_future,
                         num_threads=num_threads, pure=False, **options)
    statuses, parts = [], []
    for video, future in zip(videos, futures):
        try:
            status = future.result()
        except Exception as e:  # the task itself died (a worker lost, a crash): report it, keep the others
            status = {"video": video, "end": "failed", "frames": 0, "n_ok": 0, "n_lost": 0, "seconds": 0.0,
                      "error": f"{type(e).__name__}: {e}", "warnings": [], "rows": None}
        rows = status.pop("rows")
        statuses.append(status)
        if rows is not None:
            part = np.empty(len(rows), dtype=table_dtype(videos))
            part["video"] = video
            for name in pt.POSE_DTYPE.names:
                part[name] = rows[name]
            parts.append(part)
    table = np.concatenate(parts) if parts else np.empty(0, dtype=table_dtype(videos))
    return table, statuses


def write_table(path, table):
    """The table as CSV: pose CSV columns after `video`; floats written in full
    (shortest round trip), NaN as an empty field like panoloc."""
    def field(value):
        if isinstance(value, (float, np.floating)):
            return "" if np.isnan(value) else repr(float(value))
        return str(value)

    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(table.dtype.names)
        for row in table.tolist():
            writer.writerow([field(v) for v in row])


def read_table(path):
    """A table written by write_table, back as the structured array."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        lines = list(reader)
    assert header == ["video", *pt.POSE_DTYPE.names], header
    videos = [line[0] for line in lines]
    table = np.empty(len(lines), dtype=table_dtype(videos))
    for i, line in enumerate(lines):
        table[i] = tuple(v if table.dtype[k].kind == "U" else (float(v) if v else np.nan)
                         for k, v in zip(header, line))
    return table


def status_line(status):
    """One line per video, as panoloc prints it."""
    if status["end"] == "failed" and status["frames"] == 0:
        return f"{status['video']}: failed: {status['error']}"
    line = f"{status['video']}: {status['frames']} frames, {status['n_ok']} ok, {status['n_lost']} lost"
    if status["end"] != "done":
        line += f", {status['end']}" + (f": {status['error']}" if status["error"] else "")
    return line


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://host:8786)")
    where.add_argument("--local-workers", type=int, help="start a local cluster of N worker processes")
    parser.add_argument("--calib", required=True, help="calibration YAML")
    parser.add_argument("--map", required=True, help="map YAML")
    parser.add_argument("--out", required=True, help="the table of every video's poses (CSV)")
    parser.add_argument("--method", default="junction", choices=["junction", "vertex"])
    parser.add_argument("--threads-per-video", type=int, default=1, help="threads of each localisation")
    parser.add_argument("videos", nargs="+", help="videos, image folders or printf patterns")
    args = parser.parse_args(argv)

    from dask.distributed import Client, LocalCluster

    try:
        calibration, room = pt.read_calibration(args.calib), pt.read_map(args.map)
    except pt.Error as e:
        print(f"dask_localize: {e}", file=sys.stderr)
        return 2
    with contextlib.ExitStack() as stack:
        if args.scheduler:
            client = stack.enter_context(Client(args.scheduler))
        else:
            cluster = stack.enter_context(LocalCluster(n_workers=args.local_workers, threads_per_worker=1,
                                                       processes=True, dashboard_address=None))
            client = stack.enter_context(Client(cluster))
        table, statuses = localize_all(client, args.videos, calibration, room,
                                       num_threads=args.threads_per_video, method=args.method)
    write_table(args.out, table)
    for status in statuses:
        print(status_line(status))
    failed = sum(s["end"] == "failed" for s in statuses)
    print(f"{len(table)} rows of {len(statuses) - failed} of {len(statuses)} videos -> {args.out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
