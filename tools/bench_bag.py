#!/usr/bin/env python3
"""Recordings against video: the 3000 frames of panosim's long-run clip
(decoded from its H.264 video.mp4) written as a ROS 1 bag, a ROS 2 sqlite3
bag and an MCAP file (mono8) and a ROS 2 bag of JPEG CompressedImages
(quality 90); times, in one run, reading the frames alone
(panotrack.FrameReader over the MP4 against panotrack.bag.BagFrames over
each recording) and localising through them (localize_video against
localize_bag), alternating so that a load change hits both alike; prints a
Markdown table of medians and the ratios to the MP4, with the frames
tracked and their error against the ground truth, and how far the rows are
the MP4's.

Usage: tools/bench_bag.py [--build BUILD] [--work WORK] [--repeat N] [--localize-repeat N] [--threads N]
  BUILD  holds bin/panosim and python/ (the module; default: build)
  WORK   clips and recordings; kept, and what is found there is reused
         (default: a new temporary folder)
Needs rosbags, mcap and cv2 (scripts/install-deps.sh) and about 2.5 GB of
disk in WORK.
"""
import argparse
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--work")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each read (median)")
    ap.add_argument("--localize-repeat", type=int, default=1, help="runs of each localisation (median)")
    ap.add_argument("--threads", type=int, default=2, help="localiser threads (both paths)")
    ap.add_argument("--supersample", type=int, default=1, help="panosim --supersample of the clip")
    args = ap.parse_args()
    build = pathlib.Path(args.build).resolve()
    sys.path.insert(0, str(build / "python"))
    import numpy as np
    import panotrack as pt
    from panotrack import bag

    work = pathlib.Path(args.work or tempfile.mkdtemp(prefix="pano_bench_bag_"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"bench_bag: working in {work}", file=sys.stderr)
    clip = work / "long"
    if not (clip / "video.mp4").exists():
        subprocess.run([str(build / "bin" / "panosim"), "sequence", "--preset", "long-run", "--supersample",
                        str(args.supersample), "-o", str(clip), "-q", "--force"], check=True)
    video = clip / "video.mp4"
    frames = None
    stamps = None
    recordings = [("ROS 1 bag, mono8", work / "long.bag", "mono8", None),
                  ("ROS 2 bag (sqlite3), mono8", work / "long_sqlite3", "mono8", "sqlite3"),
                  ("MCAP file, mono8", work / "long.mcap", "mono8", None),
                  ("ROS 2 bag (sqlite3), JPEG 90", work / "long_jpeg", "jpeg", "sqlite3")]
    for _, path, encoding, storage in recordings:
        if path.exists():
            continue
        if frames is None:
            frames = [f for f, _ in pt.FrameReader(video)]
            stamps = [i * 100_000_000 for i in range(len(frames))]
        t = time.monotonic()
        bag.write_image_bag(path, frames, stamps, topic="/camera/image", encoding=encoding,
                            storage=storage or "sqlite3", jpeg_quality=90)
        print(f"bench_bag: wrote {path} in {time.monotonic() - t:.1f} s", file=sys.stderr)
    frames = None
    size = lambda p: sum(f.stat().st_size for f in (p.iterdir() if p.is_dir() else [p]))  # noqa: E731

    def read_video():
        n = 0
        for _ in pt.FrameReader(video):
            n += 1
        return n

    def read_bag(path):
        n = 0
        for _ in bag.BagFrames(path, "/camera/image"):
            n += 1
        return n

    # Reading alone: each recording against the MP4, alternating.
    read_times = {"MP4 (H.264)": []}
    for name, *_ in recordings:
        read_times[name] = []
    for _ in range(args.repeat):
        for name, path, *_ in recordings:
            t = time.monotonic()
            assert read_video() == 3000
            read_times["MP4 (H.264)"].append(time.monotonic() - t)
            t = time.monotonic()
            assert read_bag(path) == 3000
            read_times[name].append(time.monotonic() - t)

    # Localisation: localize_video against localize_bag, alternating.
    from ruamel.yaml import YAML
    p = YAML(typ="safe", pure=True).load((clip / "case.yaml").read_text())["initial_pose"]
    case_init = (float(p["x"]), float(p["y"]), float(p["theta"]))
    calib, map_path = clip / "calib.yaml", clip / "map.yaml"
    loc_times = {"MP4 (H.264)": []}
    rows_of = {}
    for name, *_ in recordings:
        loc_times[name] = []
    for _ in range(args.localize_repeat):
        for name, path, *_ in recordings:
            t = time.monotonic()
            rows_of["MP4 (H.264)"] = pt.localize_video(video, calib, map_path, init=case_init,
                                                       num_threads=args.threads)
            loc_times["MP4 (H.264)"].append(time.monotonic() - t)
            t = time.monotonic()
            rows_of[name] = pt.localize_bag(path, "/camera/image", calib, map_path, init=case_init,
                                            num_threads=args.threads)
            loc_times[name].append(time.monotonic() - t)

    ref = rows_of["MP4 (H.264)"]
    gt = np.genfromtxt(clip / "gt.csv", delimiter=",", names=True)

    def accuracy(rows):
        ok = rows["status"] == "ok"
        err = np.hypot(rows["x"] - gt["x"], rows["y"] - gt["y"])[ok]
        return f"{ok.sum()} ok, RMS {np.sqrt(np.mean(err ** 2)):.4f}"

    print("| input | size | read 3000 frames | ratio | localise 3000 frames | ratio | tracked, error | rows |")
    print("|---|---:|---:|---:|---:|---:|---|---|")
    for name in read_times:
        path = video if name.startswith("MP4") else next(r[1] for r in recordings if r[0] == name)
        r = statistics.median(read_times[name])
        r0 = statistics.median(read_times["MP4 (H.264)"])
        lt = statistics.median(loc_times[name])
        l0 = statistics.median(loc_times["MP4 (H.264)"])
        rows = rows_of[name]
        if name.startswith("MP4"):
            same = "-"
        else:
            differ = np.nonzero((rows["status"] != ref["status"]) | ~np.isclose(rows["x"], ref["x"], rtol=0, atol=0,
                                                                                 equal_nan=True))[0]
            same = "as the MP4's" if not len(differ) else f"the MP4's up to frame {differ[0] - 1}"
        print(f"| {name} | {size(path) / 2**20:.0f} MiB | {r:.2f} s | {r / r0:.2f} | {lt:.1f} s | {lt / l0:.2f} "
              f"| {accuracy(rows)} | {same} |")


if __name__ == "__main__":
    main()
