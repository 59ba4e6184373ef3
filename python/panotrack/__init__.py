"""panotrack: robot localisation with catadioptric panoramic cameras.

The sensor model (project, backproject, E(D, Z)), calibration and map files,
calibration from chessboard images, and localisation (per frame or through a
whole video, as panoloc, or through a robot's recording: localize_bag) from
the C++ library, with numpy arrays in and out.
"""

import copy
import os
import tempfile
import warnings

import numpy as np

from . import _panotrack

if int(np.__version__.split(".")[0]) >= 2 and tuple(_panotrack.pybind11_version) < (2, 12):
    raise ImportError(
        "panotrack: this build uses pybind11 %d.%d, which does not support numpy %s (arrays would come back "
        "corrupted); install numpy<2, or rebuild with pybind11 >= 2.12 (pip install . does)"
        % (_panotrack.pybind11_version[0], _panotrack.pybind11_version[1], np.__version__))

from ._panotrack import (  # noqa: F401,E402
    Calibration,
    CalibrationResult,
    Error,
    FrameReader,
    Localizer,
    Map,
    ParameterEstimate,
    Sensor,
    calibrate,
    read_calibration,
    read_map,
    sphere_sensor,
    write_calibration,
    write_map,
)
from . import _panotrack

__all__ = [
    "Calibration", "CalibrationResult", "Error", "FrameReader", "Localizer", "Map", "ParameterEstimate",
    "Sensor", "calibrate", "read_calibration", "read_map", "sphere_sensor", "write_calibration",
    "write_map", "localize_video", "POSE_DTYPE", "localize_bag", "write_pose_mcap",
]

__version__ = "0.1.0"

#: The columns of panoloc's pose CSV (docs/panoloc.md), one record per frame.
#: Empty CSV fields (lost frames' pose and residual, missing standard
#: deviations) are NaN.
POSE_DTYPE = np.dtype([
    ("frame", np.int32), ("time_s", np.float64), ("x", np.float64), ("y", np.float64),
    ("theta_rad", np.float64), ("status", "U4"), ("n_landmarks", np.int32), ("residual", np.float64),
    ("std_x", np.float64), ("std_y", np.float64), ("std_theta", np.float64), ("quality", np.float64),
])


def _file_of(obj, write, name, folder):
    """The path of `obj` (a path, or an object written to a file in `folder`)."""
    if isinstance(obj, (str, os.PathLike)):
        return os.fspath(obj)
    path = os.path.join(folder, name)
    write(path, obj)
    return path


def _write_calibration_beside(path, calib):
    # The table's path is relative to the original file's folder: keep the
    # resolved one so that the copy finds it.
    if calib.lut:
        calib = copy.copy(calib)
        calib.lut = calib.lut_resolved
    write_calibration(path, calib)


def localize_video(path, calibration, map, method="junction", init=None, fps=0.0, num_threads=0, gt=None,
                   return_summary=False, **localizer_options):
    """Localises through a whole video (or image folder) as panoloc does.

    Runs the library's RunPanoloc on the one input, so the rows are exactly
    the ones panoloc writes to its pose CSV (same rounding). Returns a numpy
    structured array of POSE_DTYPE; with return_summary, also a dict (end,
    frames, n_ok, n_lost, seconds, error, accuracy against `gt` when given).

    calibration, map: file paths or Calibration / Map objects. init: (x, y,
    theta) guess of the first pose; None: the case.yaml beside the input,
    else a room-wide search (as panoloc). fps > 0: time_s = frame / fps.
    localizer_options: search_px, min_step, alert_fraction (panoloc's
    --search-px, --min-step, --alert-fraction). Raises panotrack.Error when
    the input cannot be used; warns when it ended early or too few frames
    were tracked.
    """
    with tempfile.TemporaryDirectory(prefix="panotrack_") as folder:
        calib_path = _file_of(calibration, _write_calibration_beside, "calib.yaml", folder)
        map_path = _file_of(map, write_map, "map.yaml", folder)
        columns, summary = _panotrack._localize_video(
            os.fspath(path), calib_path, map_path, method, None if init is None else tuple(init), float(fps),
            int(num_threads), "" if gt is None else os.fspath(gt), **localizer_options)
    rows = np.empty(len(columns["frame"]), dtype=POSE_DTYPE)
    for name in POSE_DTYPE.names:
        rows[name] = columns[name]
    if summary["end"] != "done" and not return_summary:
        warnings.warn(f"localize_video: {summary['end']}: {summary['error']}", RuntimeWarning, stacklevel=2)
    return (rows, summary) if return_summary else rows


# Recordings (ROS 1 and ROS 2 bags, MCAP files): their readers (rosbags,
# mcap, cv2) are imported when first used.
from .bag import localize_bag, write_pose_mcap  # noqa: E402
