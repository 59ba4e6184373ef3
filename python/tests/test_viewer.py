"""The run viewer (panotrack.viewer, Rerun): a run recorded to an .rrd file
holds, frame by frame, the image, the edges and junctions the localiser
measured, the pose, its covariance and the trajectory; the viewer changes
no row; and the per-frame details it draws are the localiser's."""
import math
import sys

import numpy as np
import pytest

import panotrack as pt
from conftest import run

pytest.importorskip("rosbags", reason="reading recordings needs rosbags (scripts/install-deps.sh)")
pytest.importorskip("mcap", reason="MCAP files need mcap (scripts/install-deps.sh)")
rr = pytest.importorskip("rerun", reason="the viewer needs rerun-sdk (scripts/install-deps.sh)")

from panotrack import bag, viewer  # noqa: E402
from test_bag import STEP_NS, TOPIC, case_init, csv_text  # noqa: E402

N = 12  # frames recorded


@pytest.fixture(scope="module")
def recording(sequence, tmp_path_factory):
    """The first N frames as an MCAP file."""
    path = tmp_path_factory.mktemp("view") / "run.mcap"
    frames = [f for f, _ in pt.FrameReader(sequence / "frames")][:N]
    bag.write_image_bag(path, frames, [i * STEP_NS for i in range(N)], topic=TOPIC)
    return path


def localizer_details(sequence, recording):
    """Localizer.track(details=True) on the recording's frames, as localize_bag drives it."""
    loc = pt.Localizer(sequence / "calib.yaml", sequence / "map.yaml", init=case_init(sequence))
    return [loc.track(grey, stamp / 1e9, True) for grey, stamp in bag.BagFrames(recording, TOPIC)]


def test_track_details_are_what_the_localiser_measured(sequence, recording):
    loc = pt.Localizer(sequence / "calib.yaml", sequence / "map.yaml", init=case_init(sequence))
    plain = [loc.track(grey, stamp / 1e9) for grey, stamp in bag.BagFrames(recording, TOPIC)]
    detailed = localizer_details(sequence, recording)
    m = pt.read_map(sequence / "map.yaml")
    corners = dict(zip(m.landmark_ids, m.landmark_corners))
    for a, b in zip(plain, detailed):
        assert "landmarks" not in a
        # Asking for the details changes nothing else.
        assert bag.format_pose_row(a) == bag.format_pose_row(b)
        lm = b["landmarks"]
        k = len(lm["ids"])
        assert k >= 4 and set(lm["ids"]) <= set(m.landmark_ids)
        assert lm["found"].shape == (k,) and lm["predicted_edge_px"].shape == (k, 2, 2)
        # Every landmark used for the pose was found (the triangulation may leave out some found ones).
        assert lm["found"].sum() >= b["n_landmarks"] and b["status"] == "ok"
        found = lm["found"]
        assert np.isfinite(lm["junction_px"][found]).all() and np.isnan(lm["junction_px"][~found]).all()
        assert all(w for w, f in zip(lm["why"], found) if not f) and not any(w for w, f in zip(lm["why"], found) if f)
        np.testing.assert_array_equal(lm["corner_world"], [corners[i] for i in lm["ids"]])
        # The vertical edge's first end is the predicted corner; the junctions
        # lie within the search window of the prediction (8 px by default,
        # the corner moves under 3 px between these frames).
        np.testing.assert_allclose(lm["predicted_edge_px"][:, 0], lm["predicted_corner_px"], atol=1e-6)
        d = np.hypot(*(lm["junction_px"][found] - lm["predicted_corner_px"][found]).T)
        assert d.max() < 8.0, d
        assert len(lm["edge_points_px"]) == len(lm["edge_point_landmark"]) > 10 * found.sum()
        assert set(lm["edge_point_landmark"].tolist()) <= set(range(k))
        assert ((lm["edge_points_px"] >= 0) & (lm["edge_points_px"] < 500)).all()


def table(rec, entity, column):
    """The values of one component of an entity, per frame it was logged at."""
    view = rec.view(index="frame", contents={entity: [column]})
    t = view.select().read_all()
    name = f"/{entity}:{column}"
    return {f: v for f, v in zip(t.column("frame").to_pylist(), t.column(name).to_pylist()) if v is not None}


def test_run_recorded_to_rrd(sequence, recording, tmp_path):
    rrd = tmp_path / "run.rrd"
    plain = pt.localize_bag(recording, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                            init=case_init(sequence))
    rows = pt.localize_bag(recording, TOPIC, sequence / "calib.yaml", sequence / "map.yaml",
                           init=case_init(sequence), view=rrd)
    # The viewer changes no row.
    assert csv_text(rows) == csv_text(plain)
    details = localizer_details(sequence, recording)
    rec = rr.dataframe.load_recording(str(rrd))
    assert rec.application_id() == "panotrack"

    images = table(rec, "camera/image", "ImageBuffer")
    assert sorted(images) == list(range(N))
    frames = [f for f, _ in pt.FrameReader(sequence / "frames")]
    for i in (0, N - 1):
        np.testing.assert_array_equal(np.asarray(images[i][0], dtype=np.uint8).reshape(500, 500), frames[i])

    junctions = table(rec, "camera/image/junctions", "Position2D")
    labels = table(rec, "camera/image/junctions", "Text")
    edges = table(rec, "camera/image/edge_points", "Position2D")
    predicted = table(rec, "camera/image/predicted_edges", "LineStrip2D")
    translations = table(rec, "world/robot", "Translation3D")
    ellipses = table(rec, "world/covariance", "LineStrip3D")
    segments = table(rec, "world/trajectory", "LineStrip3D")
    std_x = table(rec, "plots/position/std_x", "Scalar")
    for i, d in enumerate(details):
        lm = d["landmarks"]
        found = lm["found"]
        np.testing.assert_allclose(np.array(junctions[i], dtype=np.float64), lm["junction_px"][found], atol=1e-4)
        assert list(labels[i]) == [x for x, f in zip(lm["ids"], found) if f]
        np.testing.assert_allclose(np.array(edges[i], dtype=np.float64), lm["edge_points_px"], atol=1e-4)
        assert len(predicted[i]) == len(lm["ids"])
        np.testing.assert_allclose(translations[i][0], [rows["x"][i], rows["y"][i], 0.0], atol=1e-4)
        assert std_x[i][0] == pytest.approx(d["std_x"], rel=1e-6)
        # The 3-sigma ellipse of the position covariance: its farthest point
        # is 3 times the larger standard deviation away from the pose.
        (ring,) = ellipses[i]
        ring = np.array(ring, dtype=np.float64)
        r = np.hypot(ring[:, 0] - d["x"], ring[:, 1] - d["y"])
        big = math.sqrt(np.linalg.eigvalsh(d["covariance"][:2, :2]).max())
        assert r.max() == pytest.approx(3 * big, rel=1e-3)
    # One trajectory segment per frame after the first, from pose to pose.
    assert sorted(segments) == list(range(1, N))
    for i in range(1, N):
        ((a, b),) = segments[i]
        np.testing.assert_allclose([a[:2], b[:2]], [[rows["x"][i - 1], rows["y"][i - 1]], [rows["x"][i], rows["y"][i]]],
                                   atol=1e-4)
    # The map: its landmark corners with their ids (static: at every frame).
    m = pt.read_map(sequence / "map.yaml")
    static = rec.view(index="frame", contents={"world/landmarks/corners": ["Position3D", "Text"]}) \
        .select_static().read_all()
    (corners,) = static.column("/world/landmarks/corners:Position3D").to_pylist()
    (ids,) = static.column("/world/landmarks/corners:Text").to_pylist()
    np.testing.assert_allclose(np.array(corners, dtype=np.float64), m.landmark_corners, atol=1e-4)
    assert list(ids) == list(m.landmark_ids)


def test_command_view_flag(sequence, recording, tmp_path):
    rrd = tmp_path / "cli.rrd"
    out = tmp_path / "poses.csv"
    argv = [sys.executable, "-m", "panotrack.bag_cli", "localize", str(recording), "--calib",
            str(sequence / "calib.yaml"), "--map", str(sequence / "map.yaml"), "-o", str(out),
            "--init", ",".join(repr(v) for v in case_init(sequence)), "--view", str(rrd)]
    r = run(argv)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[-1] == f"  view -> {rrd}"
    rec = rr.dataframe.load_recording(str(rrd))
    assert sorted(table(rec, "camera/image", "ImageBuffer")) == list(range(N))
    # An existing recording is kept without --force; a view that is neither
    # a file nor an address is refused.
    out.unlink()
    r = run(argv)
    assert r.returncode == 1 and r.stderr.strip() == \
        f"panotrack-bag: {rrd}: exists (use --force, or force=True, to replace it)"
    r = run(argv[:-1] + ["nowhere", "--force"])
    assert r.returncode == 1 and r.stderr.strip() == \
        "panotrack-bag: --view: expected nothing, FILE.rrd or HOST:PORT, got 'nowhere'"


def test_open_viewer_refuses_unknown(sequence):
    with pytest.raises(ValueError, match="view: expected True, 'spawn', a path ending in .rrd"):
        viewer.open_viewer("run.txt", pt.read_map(sequence / "map.yaml"))
