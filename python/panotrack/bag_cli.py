"""panotrack-bag: localise a robot from a recording (ROS 1 bag, ROS 2 bag,
MCAP file) and write the poses as panoloc does, and as ROS messages.

  panotrack-bag info BAG
  panotrack-bag localize BAG --topic /camera/image --calib calib.yaml --map map.yaml -o poses.csv
                [--tum poses.tum] [--summary-json summary.json] [--mcap [OUT.mcap]] [--force] ...

Also runs as `python3 -m panotrack.bag_cli`. Outputs are written as
OUT.partial and renamed when complete; existing outputs are kept unless
--force is given, and no output may be the input. Exit status: 0 success;
1 bad options or files, an existing output without --force, or a recording
that failed, broke off or was hardly tracked; 130 stopped by Ctrl-C (the
rows so far are kept); 2 unexpected internal error.
"""

import argparse
import json
import math
import os
import pathlib
import sys

PROG = "panotrack-bag"


def _parser():
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Localise a robot from a recording of its catadioptric panoramic camera (ROS 1 .bag, "
                    "ROS 2 bag folder or .db3, MCAP file; sensor_msgs/Image or CompressedImage), through "
                    "panoloc's localiser, and write the poses as panoloc's CSV, a TUM trajectory and ROS "
                    "messages (geometry_msgs/PoseWithCovarianceStamped, tf) in a new MCAP file.",
        epilog="Exit status: 0 success; 1 bad options or files, an existing output without --force, or a "
               "recording that failed, broke off or was hardly tracked; 130 stopped by Ctrl-C (the rows so "
               "far are kept).")
    sub = p.add_subparsers(dest="command", required=True, metavar="{info,localize}")
    info = sub.add_parser("info", help="List the recording's topics (image topics marked)")
    info.add_argument("bag", help="ROS 1 .bag, ROS 2 bag folder or .db3 file, or .mcap file")

    loc = sub.add_parser("localize", help="Localise through the frames of an image topic",
                         description="Localise through the frames of one image topic, as panoloc through a "
                                     "video: the same localiser, the same pose CSV (time_s the messages' "
                                     "header stamps).")
    loc.add_argument("bag", help="ROS 1 .bag, ROS 2 bag folder or .db3 file, or .mcap file")
    io = loc.add_argument_group("Inputs and outputs")
    io.add_argument("--topic", help="Image topic (sensor_msgs/Image or CompressedImage); default: the only one")
    io.add_argument("--calib", required=True, help="Calibration YAML (panocalib's output)")
    io.add_argument("--map", required=True, help="Map YAML of the room's landmarks")
    io.add_argument("-o", "--output", required=True, help="Output pose CSV (panoloc's columns)")
    io.add_argument("--tum", help="Also write the ok frames as a TUM trajectory (t x y z qx qy qz qw, metres)")
    io.add_argument("--mcap", nargs="?", const="auto", metavar="OUT.mcap",
                    help="Also write the ok poses as geometry_msgs/PoseWithCovarianceStamped and tf "
                         "(map -> base_link) to a new MCAP file; without a name: <recording>.poses.mcap "
                         "beside the recording")
    io.add_argument("--metres-per-unit", type=float, default=0.0,
                    help="Metres per map unit in the TUM and MCAP outputs (0: from the map's units)")
    io.add_argument("--map-frame", default="map", help="Frame of the poses in the MCAP (default: map)")
    io.add_argument("--base-frame", default="base_link", help="The robot's frame in the MCAP (default: base_link)")
    io.add_argument("--pose-topic", default="/panotrack/pose",
                    help="Topic of the poses in the MCAP (default: /panotrack/pose)")
    io.add_argument("--summary-json", help="Also write the summary (outputs, frames, ok, lost, frames/s, end, "
                                           "error) as JSON; - writes it to standard output")
    io.add_argument("--view", nargs="?", const="spawn", metavar="FILE.rrd|HOST:PORT",
                    help="Show the run in Rerun as it goes (the camera image with the tracked edges and junctions, "
                         "the landmarks, the trajectory and the covariance): without a value a viewer is "
                         "started; FILE.rrd records the run there for `rerun FILE.rrd`; HOST:PORT sends it to a "
                         "viewer already running. Needs rerun-sdk")
    io.add_argument("--force", action="store_true", help="Replace existing output files")
    tr = loc.add_argument_group("Tracking")
    tr.add_argument("--init", help="X,Y,THETA: a guess of the initial pose (map units, radians); default: "
                                   "initial_pose of the case.yaml beside the recording; without either, the "
                                   "first frame is localised by searching the whole room")
    tr.add_argument("--method", choices=["junction", "vertex"], default="junction", help="Tracking method")
    tr.add_argument("--search-px", type=float, help="As panoloc's --search-px")
    tr.add_argument("--min-step", type=float, help="As panoloc's --min-step")
    tr.add_argument("--alert-fraction", type=float, help="As panoloc's --alert-fraction")
    tr.add_argument("--threads", type=int, default=0, help="Tracking threads (0: all cores)")
    loc.add_argument("-q", "--quiet", action="store_true", help="No summary line (errors still on stderr)")
    return p


def _info(args, pt, bag):
    topics = bag.bag_topics(args.bag)
    width = max((len(t) for t in topics), default=0)
    for name, (msgtype, count) in sorted(topics.items()):
        mark = "  (image)" if msgtype in (bag.IMAGE_TYPE, bag.COMPRESSED_TYPE) else ""
        print(f"{name:<{width}}  {msgtype}  {count} messages{mark}")
    return 0


class _StagedText:
    """A text output written line by line to PATH.partial, renamed to PATH by commit()."""

    def __init__(self, path):
        self.path = path
        self.partial = path + ".partial"
        self.file = open(self.partial, "w")

    def line(self, text):
        self.file.write(text + "\n")
        self.file.flush()

    def commit(self):
        self.file.close()
        os.replace(self.partial, self.path)


def _tum_line(r, time_s, mpu, z):
    half = 0.5 * r["theta"]
    return "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f" % (time_s, r["x"] * mpu, r["y"] * mpu, z, 0.0, 0.0,
                                                         math.sin(half), math.cos(half))


def _localize(args, pt, bag):
    init = None
    if args.init:
        try:
            init = tuple(float(v) for v in args.init.split(","))
            if len(init) != 3:
                raise ValueError
        except ValueError:
            raise pt.Error(f"--init: expected X,Y,THETA, got '{args.init}'") from None
    mcap_out = args.mcap
    if mcap_out == "auto":
        p = pathlib.Path(args.bag)
        stem = p.name[:-len(p.suffix)] if p.suffix in (".bag", ".mcap", ".db3") else p.name
        mcap_out = str(p.parent / (stem + ".poses.mcap"))
    rrd = None
    if args.view is not None:
        from panotrack.viewer import view_target
        try:
            kind, where = view_target(args.view)
        except ValueError:
            raise pt.Error(f"--view: expected nothing, FILE.rrd or HOST:PORT, got '{args.view}'") from None
        rrd = where if kind == "save" else None
    outputs = {"poses": args.output, "tum": args.tum, "mcap": mcap_out, "view": rrd}
    if args.summary_json and args.summary_json != "-":
        outputs["summary_json"] = args.summary_json
    named = {k: v for k, v in outputs.items() if v}
    paths = [pathlib.Path(v).resolve() for v in named.values()]
    if len(set(paths)) != len(paths):
        raise pt.Error("the outputs " + ", ".join(f"{k} {v}" for k, v in named.items()) + " must be distinct")
    for what, out in named.items():
        bag._output_guard(out, [args.bag, args.calib, args.map], args.force, what)
    m = pt.read_map(args.map)
    mpu = args.metres_per_unit if args.metres_per_unit > 0 else 1.0 / m.units_per_metre()
    options = {k: getattr(args, k) for k in ("search_px", "min_step", "alert_fraction") if getattr(args, k) is not None}

    csv = tum = None
    try:
        csv = _StagedText(args.output)
        csv.line(bag.POSE_CSV_HEADER)
        tum = _StagedText(args.tum) if args.tum else None

        def on_frame(index, grey, r):
            csv.line(bag.format_pose_row(r))
            if tum is not None and r["status"] == "ok":
                tum.line(_tum_line(r, r["time_s"], mpu, m.sensor_height * mpu))

        rows, summary = bag.localize_bag(args.bag, args.topic, args.calib, m, method=args.method, init=init,
                                         num_threads=args.threads, return_summary=True, on_frame=on_frame,
                                         view=args.view, **options)
        csv.commit()
        if tum is not None:
            tum.commit()
    except BaseException:
        for out in (csv, tum):
            if out is not None and not out.file.closed:
                out.file.close()
        raise
    if mcap_out:
        bag.write_pose_mcap(mcap_out, rows, summary["covariance"], summary["stamp_ns"], metres_per_unit=mpu,
                            map_frame=args.map_frame, base_frame=args.base_frame, pose_topic=args.pose_topic,
                            inputs=[args.bag], force=args.force)
    s = summary
    fps = s["frames"] / s["seconds"] if s["seconds"] > 0 else 0.0
    if args.summary_json:
        doc = {"tool": PROG, "version": pt.__version__, "command_line": [PROG] + args.argv,
               "inputs": [{"input": s["input"], "topic": s["topic"], "end": s["end"], "done": s["end"] == "done",
                           "error": s["error"], "frames": s["frames"], "ok": s["n_ok"], "lost": s["n_lost"],
                           "seconds": s["seconds"], "frames_per_s": fps,
                           "outputs": {k: v for k, v in outputs.items() if v and k != "summary_json"}}]}
        text = json.dumps(doc, indent=2) + "\n"
        if args.summary_json == "-":
            sys.stdout.write(text)
        else:
            staged = _StagedText(args.summary_json)
            staged.file.write(text)
            staged.commit()
    if not args.quiet:
        out = sys.stderr if args.summary_json == "-" else sys.stdout
        print(f"{s['input']} ({s['topic']}): {s['frames']} frames, {s['n_ok']} ok, {s['n_lost']} lost, "
              f"{fps:.1f} frames/s -> {args.output}", file=out)
        if args.tum:
            print(f"  TUM -> {args.tum}", file=out)
        if mcap_out:
            print(f"  MCAP -> {mcap_out}", file=out)
        if rrd:
            print(f"  view -> {rrd}", file=out)
    if s["end"] == "interrupted":
        return 130
    if s["end"] != "done":
        print(f"{PROG}: {s['input']}: {s['end']}: {s['error']}", file=sys.stderr)
        return 1
    return 0


def main(argv=None):
    """The command's entry point; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(argv)
    args.argv = argv
    try:
        import panotrack as pt
        from panotrack import bag
        return _info(args, pt, bag) if args.command == "info" else _localize(args, pt, bag)
    except KeyboardInterrupt:
        return 130
    except (RuntimeError, ValueError, OSError) as e:
        # The library's errors (panotrack.Error, a RuntimeError) name their
        # file, as the file system's do.
        print(f"{PROG}: {' '.join(str(e).split()) or type(e).__name__}", file=sys.stderr)
        return 1
    except Exception as e:
        print(f"{PROG}: unexpected error: {type(e).__name__}: {' '.join(str(e).split())}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
