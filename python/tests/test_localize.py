"""Localisation from Python against panoloc: localize_video runs panoloc's own
pipeline function, so its rows equal the program's CSV; the per-frame
Localizer follows the same path frame by frame."""
import csv
import math

import numpy as np
import pytest

import panotrack as pt
from conftest import program, run

COLUMNS = ["frame", "time_s", "x", "y", "theta_rad", "status", "n_landmarks", "residual",
           "std_x", "std_y", "std_theta", "quality"]


def read_pose_csv(path):
    """A pose CSV as a POSE_DTYPE array (empty fields NaN), read with csv."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        assert next(reader) == COLUMNS
        rows = [tuple(v if k == "status" else (float(v) if v else math.nan) for k, v in zip(COLUMNS, line))
                for line in reader]
    return np.array(rows, dtype=pt.POSE_DTYPE)


def assert_rows_equal(a, b, tol=1e-9):
    assert len(a) == len(b)
    for name in pt.POSE_DTYPE.names:
        if a.dtype[name].kind in "fi":
            np.testing.assert_allclose(a[name], b[name], rtol=0, atol=tol, equal_nan=True, err_msg=name)
        else:
            assert (a[name] == b[name]).all(), name


def panoloc(seq, out, *args):
    r = run([program("panoloc"), str(seq / "video.mp4"), "--calib", str(seq / "calib.yaml"),
             "--map", str(seq / "map.yaml"), "-o", str(out), "-q", *args])
    assert r.returncode == 0, r.stderr
    return read_pose_csv(out)


@pytest.mark.parametrize("method", ["junction", "vertex"])
def test_localize_video_equals_panoloc(sequence, tmp_path, method):
    expected = panoloc(sequence, tmp_path / "panoloc.csv", "--method", method)
    assert len(expected) == 66 and (expected["status"] == "ok").all()
    rows, summary = pt.localize_video(sequence / "video.mp4", sequence / "calib.yaml", str(sequence / "map.yaml"),
                                      method=method, gt=sequence / "gt.csv", return_summary=True)
    assert rows.dtype == pt.POSE_DTYPE
    assert_rows_equal(rows, expected)
    assert summary["end"] == "done" and summary["n_ok"] == 66 and summary["frames"] == 66
    # The paper-synthetic accuracy of the README's table (0.018 / 0.014 units).
    assert summary["accuracy"]["compared"] == 66
    assert summary["accuracy"]["rms"] < 0.03


def test_localize_video_with_objects_and_options(sequence, tmp_path):
    # Calibration and Map objects (written to scratch files), an explicit
    # first pose and panoloc's tracking options.
    gt = read_pose_csv_gt(sequence / "gt.csv")
    init = (gt["x"][0] + 0.5, gt["y"][0] - 0.5, gt["theta_rad"][0] + 0.01)
    args = ["--init", ",".join(f"{v:.9g}" for v in init), "--search-px", "10", "--fps", "25"]
    expected = panoloc(sequence, tmp_path / "panoloc.csv", *args)
    rows = pt.localize_video(str(sequence / "video.mp4"), pt.read_calibration(sequence / "calib.yaml"),
                             pt.read_map(sequence / "map.yaml"), init=[float(f"{v:.9g}") for v in init],
                             fps=25, search_px=10)
    assert_rows_equal(rows, expected)
    np.testing.assert_allclose(rows["time_s"], np.arange(66) / 25, atol=1e-6)


def read_pose_csv_gt(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        rows = list(reader)
    return {k: np.array([float(r[k]) for r in rows]) for k in ("x", "y", "theta_rad")}


def test_localizer_per_frame_follows_panoloc(sequence):
    gt = read_pose_csv_gt(sequence / "gt.csv")
    init = (gt["x"][0], gt["y"][0], gt["theta_rad"][0])
    expected = pt.localize_video(sequence / "video.mp4", sequence / "calib.yaml", sequence / "map.yaml", init=init)
    loc = pt.Localizer(pt.read_calibration(sequence / "calib.yaml"), sequence / "map.yaml", init=init)
    reader = pt.FrameReader(sequence / "video.mp4")
    assert (reader.width, reader.height, reader.frame_count) == (500, 500, 66)
    results = [loc.track(frame, time_s) for frame, time_s in reader]
    assert loc.next_frame == 66
    got = np.array([(r["frame"], r["time_s"], r["x"], r["y"], r["theta"], r["status"], r["n_landmarks"],
                     r["residual"], r["std_x"], r["std_y"], r["std_theta"], r["quality"]) for r in results],
                   dtype=pt.POSE_DTYPE)
    # The CSV's rounding: %.4f positions and residuals, %.6f angles and
    # times, %.6g standard deviations.
    for name, tol in [("time_s", 5e-7), ("x", 5e-5), ("y", 5e-5), ("theta_rad", 5e-7), ("residual", 5e-5)]:
        np.testing.assert_allclose(got[name], expected[name], rtol=0, atol=tol, err_msg=name)
    for name in ("std_x", "std_y", "std_theta", "quality"):
        np.testing.assert_allclose(got[name], expected[name], rtol=5e-6, err_msg=name)
    assert (got["status"] == expected["status"]).all()
    assert (got["n_landmarks"] == expected["n_landmarks"]).all()
    # The covariance's diagonal gives the standard deviations.
    for r in results:
        cov = r["covariance"]
        assert cov.shape == (3, 3)
        np.testing.assert_allclose(np.sqrt(np.diag(cov)), [r["std_x"], r["std_y"], r["std_theta"]], rtol=1e-12)
        np.testing.assert_allclose(cov, cov.T, atol=1e-15)
    # Positions within the README's accuracy of the ground truth.
    assert np.abs(got["x"] - gt["x"]).max() < 0.2 and np.abs(got["y"] - gt["y"]).max() < 0.2


def test_localizer_searches_the_room_without_init(sequence):
    loc = pt.Localizer(sequence / "calib.yaml", sequence / "map.yaml")
    frames = pt.FrameReader(sequence / "frames")
    statuses = [loc.track(frame)["status"] for (frame, _), _ in zip(frames, range(4))]
    assert statuses[-1] == "ok"  # relocalised by the room-wide search


def test_localizer_reports_a_held_frame_once_confirmed(tmp_path):
    # paper-synthetic on a map measured to 2 cm (seed 9), no start: the
    # search's pose of frame 0 is held (reported lost); frame 1 confirms it
    # and carries frame 0's report, ok, as panoloc writes it (measured:
    # 0.34 cm off).
    out = tmp_path / "seq"
    r = run([program("panosim"), "sequence", "--preset", "paper-synthetic", "--map-sigma", "2", "--map-seed", "9",
             "--frames", "--no-video", "-q", "-o", str(out)])
    assert r.returncode == 0, r.stderr
    gt = read_pose_csv_gt(out / "gt.csv")
    loc = pt.Localizer(out / "calib.yaml", out / "map.yaml")
    frames = pt.FrameReader(out / "frames")
    results = [loc.track(frame) for (frame, _), _ in zip(frames, range(3))]
    assert results[0]["unconfirmed"] and results[0]["status"] == "lost"
    assert results[0]["confirms_previous"] is None
    assert results[1]["status"] == "ok" and not results[1]["unconfirmed"]
    held = results[1]["confirms_previous"]
    assert held is not None and held["frame"] == 0 and held["status"] == "ok"
    assert [h["frame"] for h in results[1]["confirms"]] == [0]
    assert math.hypot(held["x"] - gt["x"][0], held["y"] - gt["y"][0]) < 0.5
    assert results[2]["confirms_previous"] is None and results[2]["confirms"] == []
    (out / "case.yaml").unlink()  # its start pose: localize_video would take it, as panoloc does
    expected = pt.localize_video(out / "frames", out / "calib.yaml", out / "map.yaml")
    np.testing.assert_allclose([held["x"], held["y"]], [expected["x"][0], expected["y"][0]], atol=5e-5)


def test_errors_carry_the_library_message(sequence, tmp_path):
    # The same one-line message as panoloc prints after "panoloc: ".
    bad = tmp_path / "bad.yaml"
    bad.write_text((sequence / "calib.yaml").read_text().replace("focal_px: 590.0", "focal_px: -5"))
    r = run([program("panoloc"), str(sequence / "video.mp4"), "--calib", str(bad), "--map",
             str(sequence / "map.yaml"), "-o", str(tmp_path / "x.csv")])
    assert r.returncode != 0
    message = r.stderr.strip().removeprefix("panoloc: ")
    assert message == f"{bad}: focal_px: expected a positive focal length in pixels"
    with pytest.raises(pt.Error) as e:
        pt.read_calibration(bad)
    assert str(e.value) == message
    assert isinstance(e.value, RuntimeError)
    with pytest.raises(pt.Error) as e:
        pt.localize_video(sequence / "video.mp4", bad, sequence / "map.yaml")
    assert str(e.value) == message

    r = run([program("panoloc"), str(sequence / "video.mp4"), "--calib", str(sequence / "calib.yaml"), "--map",
             str(sequence / "map.yaml"), "-o", str(tmp_path / "x.csv"), "--init", "1e6,0,0"])
    message = r.stderr.strip().removeprefix("panoloc: ")
    assert message.startswith("--init: (1000000.000000, 0.000000) is outside the room")
    with pytest.raises(pt.Error) as e:
        pt.localize_video(sequence / "video.mp4", sequence / "calib.yaml", str(sequence / "map.yaml"),
                          init=(1e6, 0, 0))
    assert str(e.value) == message

    with pytest.raises(pt.Error) as e:
        pt.read_map(tmp_path / "missing.yaml")
    assert str(e.value) == f"{tmp_path / 'missing.yaml'}: cannot open: No such file or directory"

    loc = pt.Localizer(sequence / "calib.yaml", sequence / "map.yaml")
    with pytest.raises(pt.Error) as e:
        loc.track(np.zeros((480, 640), np.uint8))
    assert str(e.value) == "frame 0: expected an 8-bit grey image of 500x500"
    with pytest.raises(ValueError, match="frame: expected a 2-D uint8 array"):
        loc.track(np.zeros((500, 500), np.float32))
    with pytest.raises(pt.Error) as e:
        pt.Localizer(sequence / "calib.yaml", sequence / "map.yaml", method="corner")
    assert str(e.value) == "method: expected junction or vertex, got 'corner'"


def test_map_landmarks(sequence, tmp_path):
    m = pt.read_map(sequence / "map.yaml")
    ids, corners = m.landmark_ids, m.landmark_corners
    assert corners.shape == (len(ids), 3) and len(ids) > 0
    rect = m.rectangles
    k = len(rect["ids"])
    assert rect["from"].shape == rect["to"].shape == rect["z"].shape == (k, 2)
    # Every rectangle gives four corners: its bottom-edge ends at z0 and z1.
    first = rect["ids"][0]
    mine = corners[[i for i, name in enumerate(ids) if name.startswith(first + "/")]]
    assert len(mine) == 4
    expected = {(*rect[end][0], z) for end in ("from", "to") for z in rect["z"][0]}
    assert {tuple(c) for c in mine} == expected
    import pickle
    again = pickle.loads(pickle.dumps(m))
    assert again.to_yaml(with_distractors=True) == m.to_yaml(with_distractors=True)
    pt.write_map(tmp_path / "m.yaml", m)
    back = pt.read_map(tmp_path / "m.yaml")
    assert back.landmark_ids == ids and np.array_equal(back.landmark_corners, corners)
    assert back.to_yaml() == m.to_yaml()
