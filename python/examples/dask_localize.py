"""Localise many videos at once with Dask, and project a large point cloud in
chunks.

Every panotrack call releases the GIL while it works, so Dask's threaded
scheduler runs them truly in parallel; Calibration, Map and Sensor objects
pickle, so the process and distributed schedulers take them too.

    python3 dask_localize.py CALIB.yaml MAP.yaml VIDEO... [--workers N]

prints one summary line per video, as panoloc does.
"""
import argparse

import dask
import dask.array as da
import numpy as np

import panotrack as pt


def localize_all(videos, calibration, map, workers=None, **options):
    """localize_video on every input, `workers` at a time: a list of
    (rows, summary), in the order of `videos`. Each run gets one thread of
    its own (the parallelism is across videos)."""
    tasks = [dask.delayed(pt.localize_video)(v, calibration, map, num_threads=1, return_summary=True, **options)
             for v in videos]
    return list(dask.compute(*tasks, scheduler="threads", num_workers=workers))


def project_chunked(sensor, points, chunk=250_000):
    """sensor.project over a (N, 3) array (numpy or dask) in chunks of rows:
    a dask array (N, 2) to compute, NaN where not visible."""
    points = da.asarray(points).rechunk((chunk, 3))
    return points.map_blocks(lambda block: sensor.project(block, num_threads=1), chunks=(points.chunks[0], (2,)),
                             dtype=np.float64)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("calib")
    parser.add_argument("map")
    parser.add_argument("videos", nargs="+")
    parser.add_argument("--workers", type=int, default=None, help="videos at once (default: the cores)")
    parser.add_argument("--method", default="junction", choices=["junction", "vertex"])
    args = parser.parse_args()
    calib, room = pt.read_calibration(args.calib), pt.read_map(args.map)
    for video, (rows, summary) in zip(args.videos, localize_all(args.videos, calib, room, args.workers,
                                                                method=args.method)):
        print(f"{video}: {summary['frames']} frames, {summary['n_ok']} ok, {summary['n_lost']} lost, "
              f"{summary['end']}{': ' + summary['error'] if summary['error'] else ''}")


if __name__ == "__main__":
    main()
