"""A viewer of a localisation run, live or afterwards, through Rerun
(https://rerun.io, the Python package rerun-sdk).

RunViewer logs each frame as the localiser saw it: the camera image with the
predicted vertical edges, the edge points found, the junctions (labelled with
their landmark ids) and the landmarks not found, as panoloc's debug video
draws them; in the room, the map's rectangles and boxes, the landmark
corners, the robot's pose, its trajectory so far and the 3-sigma ellipse of
its position covariance; and over time the standard deviations, the number
of landmarks and the residual. The run goes to a viewer started for it
(spawn), to one already running (connect), or to an .rrd file that `rerun
FILE.rrd` opens later.

localize_bag(..., view=...) and `panotrack-bag localize --view` create one;
without them nothing of this module is imported. Needs rerun-sdk 0.22 (the
last release that runs with numpy 1.x, which a module built with pybind11
2.10 needs).
"""

import math
import os

import numpy as np

from ._panotrack import Error

__all__ = ["RunViewer", "open_viewer", "view_target", "ENTITIES"]

#: Entity paths of the recording, by what they hold.
ENTITIES = {
    "image": "camera/image",
    "predicted_edges": "camera/image/predicted_edges",
    "edge_points": "camera/image/edge_points",
    "junctions": "camera/image/junctions",
    "not_found": "camera/image/not_found",
    "landmarks": "world/landmarks",
    "corners": "world/landmarks/corners",
    "robot": "world/robot",
    "heading": "world/robot/heading",
    "trajectory": "world/trajectory",
    "covariance": "world/covariance",
    "status": "log/status",
    "std_x": "plots/position/std_x",
    "std_y": "plots/position/std_y",
    "residual": "plots/position/residual",
    "std_theta": "plots/heading/std_theta_deg",
    "n_landmarks": "plots/landmarks/n_landmarks",
}

# The debug video's colours (pipeline/debug_draw.cc), as RGB.
_PREDICTED = (255, 200, 0)
_EDGE = (0, 220, 0)
_JUNCTION = (255, 0, 0)
_NOT_FOUND = (255, 128, 0)
_STATUS_LEVEL = {"ok": "INFO", "init": "DEBUG", "lost": "WARN"}


def _import_rerun():
    try:
        import rerun as rr
        import rerun.blueprint as rrb
    except ImportError:
        raise Error("the viewer needs the Python package rerun-sdk 0.22 (pip install 'rerun-sdk==0.22.1' "
                    "'numpy<2')") from None
    return rr, rrb


def _blueprint(rrb):
    """The camera image beside the room, the plots below the room; the
    trajectory's segments stay in view up to the time cursor."""
    history = rrb.VisibleTimeRange("frame", start=rrb.TimeRangeBoundary.infinite(),
                                   end=rrb.TimeRangeBoundary.cursor_relative())
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="camera", origin="camera"),
            rrb.Vertical(
                rrb.Spatial3DView(name="room", origin="world",
                                  overrides={ENTITIES["trajectory"]: [rrb.components.VisibleTimeRangeBatch([history])]}),
                rrb.TimeSeriesView(name="position std and residual (map units)", origin="plots/position"),
                rrb.Horizontal(rrb.TimeSeriesView(name="heading std (deg)", origin="plots/heading"),
                               rrb.TimeSeriesView(name="landmarks", origin="plots/landmarks")),
                row_shares=[4, 2, 2]),
            column_shares=[1, 1]),
        collapse_panels=True)


def _ellipse(centre, cov2, sigmas=3.0, n=48):
    """Points of the `sigmas` ellipse of a 2 x 2 covariance around centre."""
    values, vectors = np.linalg.eigh(0.5 * (cov2 + cov2.T))
    radii = sigmas * np.sqrt(np.clip(values, 0.0, None))
    t = np.linspace(0.0, 2.0 * math.pi, n + 1)
    circle = np.stack([np.cos(t) * radii[0], np.sin(t) * radii[1]])
    return (vectors @ circle).T + centre


class RunViewer:
    """Logs a run frame by frame to Rerun.

    map: the run's Map (or its path). spawn: start a Rerun viewer for it
    (the `rerun` program rerun-sdk installs); connect: the address of a
    viewer already running ("127.0.0.1:9876"); save: an .rrd file to write
    (opened later with `rerun FILE.rrd`). At least one. log_frame(index,
    grey, result) after each frame (result: Localizer.track's dict with
    details=True, or without them: then no edges); close() at the end.
    """

    def __init__(self, map, *, spawn=False, connect=None, save=None, name="panotrack", recording_id=None):
        from . import read_map
        rr, rrb = _import_rerun()
        self._rr = rr
        if not (spawn or connect or save):
            raise ValueError("RunViewer: expected spawn=True, connect=ADDRESS or save=FILE.rrd")
        m = read_map(map) if isinstance(map, (str, os.PathLike)) else map
        self.map = m
        self.save_path = None if save is None else os.fspath(save)
        rec = rr.new_recording(application_id=name, recording_id=recording_id)
        self.recording = rec
        blueprint = _blueprint(rrb)
        if self.save_path is not None:
            rec.save(self.save_path, default_blueprint=blueprint)
        if spawn:
            rec.spawn(default_blueprint=blueprint)
        elif connect:
            rec.connect(connect, default_blueprint=blueprint)
        self._previous = None  # the last frame's pose when it was ok
        self._log_map(m)

    def _log_map(self, m):
        rr, rec = self._rr, self.recording
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        strips, ids = [], []
        r = m.rectangles
        for rid, a, b, z in zip(r["ids"], r["from"], r["to"], r["z"]):
            strips.append([[a[0], a[1], z[0]], [b[0], b[1], z[0]], [b[0], b[1], z[1]], [a[0], a[1], z[1]],
                           [a[0], a[1], z[0]]])
            ids.append(rid)
        b = m.boxes
        for bid, lo, hi in zip(b["ids"], b["min"], b["max"]):
            for z in (lo[2], hi[2]):
                strips.append([[lo[0], lo[1], z], [hi[0], lo[1], z], [hi[0], hi[1], z], [lo[0], hi[1], z],
                               [lo[0], lo[1], z]])
                ids.append(bid)
            for x, y in ((lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])):
                strips.append([[x, y, lo[2]], [x, y, hi[2]]])
                ids.append(bid)
        if strips:
            rec.log(ENTITIES["landmarks"], rr.LineStrips3D(strips, colors=(160, 160, 160)), static=True)
        corners = np.asarray(m.landmark_corners, dtype=np.float64).reshape(-1, 3)
        rec.log(ENTITIES["corners"], rr.Points3D(corners, labels=list(m.landmark_ids), colors=(255, 220, 0),
                                                  radii=rr.Radius.ui_points(4.0)), static=True)
        extent = np.ptp(corners[:, :2], axis=0).max() if len(corners) else 1.0
        self._arrow = 0.1 * float(extent) if extent > 0 else 1.0
        for key, colour in (("std_x", (230, 80, 80)), ("std_y", (80, 160, 230)), ("std_theta", (120, 200, 120)),
                            ("n_landmarks", (200, 200, 200)), ("residual", (230, 160, 60))):
            rec.log(ENTITIES[key], rr.SeriesLine(color=colour, name=key), static=True)

    def log_frame(self, index, grey, result):
        """Logs one frame: its image, what the localiser measured in it and
        the pose it reported (at the timelines frame = index and time =
        result['time_s'])."""
        rr, rec = self._rr, self.recording
        rec.set_time_sequence("frame", int(index))
        rec.set_time_seconds("time", float(result["time_s"]))
        rec.log(ENTITIES["image"], rr.Image(np.ascontiguousarray(grey)))
        lm = result.get("landmarks")
        if lm is not None:
            found = np.asarray(lm["found"], dtype=bool)
            ids = list(lm["ids"])
            rec.log(ENTITIES["predicted_edges"], rr.LineStrips2D(np.asarray(lm["predicted_edge_px"]),
                                                                 colors=_PREDICTED, radii=rr.Radius.ui_points(1.0)))
            rec.log(ENTITIES["edge_points"], rr.Points2D(np.asarray(lm["edge_points_px"]), colors=_EDGE,
                                                         radii=rr.Radius.ui_points(1.5)))
            rec.log(ENTITIES["junctions"], rr.Points2D(np.asarray(lm["junction_px"])[found], colors=_JUNCTION,
                                                       labels=[i for i, f in zip(ids, found) if f],
                                                       radii=rr.Radius.ui_points(4.0)))
            rec.log(ENTITIES["not_found"], rr.Points2D(np.asarray(lm["predicted_corner_px"])[~found],
                                                       colors=_NOT_FOUND,
                                                       labels=[f"{i}: {w}" for i, w, f in zip(ids, lm["why"], found)
                                                               if not f],
                                                       radii=rr.Radius.ui_points(3.0)))
        status = result["status"]
        line = f"frame {index}: {status}, {result['n_landmarks']} landmarks"
        ok = status == "ok"
        if ok:
            x, y, theta = float(result["x"]), float(result["y"]), float(result["theta"])
            line += f", x {x:.3f} y {y:.3f} heading {math.degrees(theta):.2f} deg"
            z = float(self.map.sensor_height)
            rec.log(ENTITIES["robot"], rr.Transform3D(translation=[x, y, 0.0],
                                                      rotation=rr.RotationAxisAngle(axis=[0, 0, 1], radians=theta)))
            rec.log(ENTITIES["heading"], rr.Arrows3D(vectors=[[self._arrow, 0.0, 0.0]], origins=[[0.0, 0.0, z]],
                                                     colors=(255, 60, 60), radii=rr.Radius.ui_points(3.0)))
            cov = np.asarray(result["covariance"], dtype=np.float64)
            ring = _ellipse(np.array([x, y]), cov[:2, :2])
            rec.log(ENTITIES["covariance"],
                    rr.LineStrips3D([np.column_stack([ring, np.full(len(ring), z)])], colors=(60, 160, 255)))
            if self._previous is not None:
                rec.log(ENTITIES["trajectory"], rr.LineStrips3D([[[*self._previous, z], [x, y, z]]],
                                                                colors=(255, 60, 60), radii=rr.Radius.ui_points(2.0)))
            self._previous = (x, y)
            rec.log(ENTITIES["std_x"], rr.Scalar(float(result["std_x"])))
            rec.log(ENTITIES["std_y"], rr.Scalar(float(result["std_y"])))
            rec.log(ENTITIES["std_theta"], rr.Scalar(math.degrees(float(result["std_theta"]))))
            rec.log(ENTITIES["residual"], rr.Scalar(float(result["residual"])))
        else:
            self._previous = None
            rec.log(ENTITIES["covariance"], rr.Clear(recursive=False))
        rec.log(ENTITIES["n_landmarks"], rr.Scalar(int(result["n_landmarks"])))
        rec.log(ENTITIES["status"], rr.TextLog(line, level=_STATUS_LEVEL.get(status, "INFO")))

    def close(self):
        """Flushes the recording (and finishes the .rrd file)."""
        if self.recording is not None:
            self.recording.flush(blocking=True)
            self.recording.disconnect()
            self.recording = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def view_target(view):
    """What localize_bag's `view` argument asks for, without starting
    anything: ("spawn", None) for True or "spawn", ("save", path) for a path
    ending in .rrd, ("connect", address) for "HOST:PORT"; ValueError for
    anything else (a RunViewer is not a target: it is used as it is)."""
    if view is True or view == "spawn":
        return "spawn", None
    if isinstance(view, (str, os.PathLike)):
        text = os.fspath(view)
        if text.endswith(".rrd"):
            return "save", text
        if ":" in text:
            return "connect", text
    raise ValueError(f"view: expected True, 'spawn', a path ending in .rrd, 'HOST:PORT' or a RunViewer, got {view!r}")


def open_viewer(view, map):
    """A RunViewer for localize_bag's `view` argument: a RunViewer as it is,
    else one for view_target(view)."""
    if isinstance(view, RunViewer):
        return view
    kind, where = view_target(view)
    if kind == "spawn":
        return RunViewer(map, spawn=True)
    return RunViewer(map, save=where) if kind == "save" else RunViewer(map, connect=where)
