"""The sensor model through numpy: against the C++ library's values (single
points, numbers derived by hand in tests/sensor) on 1000 x 1000 grids."""
import math

import numpy as np
import pytest

import panotrack as pt
from conftest import SOURCE_DIR


@pytest.fixture(scope="module")
def sensor():
    return pt.read_calibration(SOURCE_DIR / "calib" / "paper-synthetic.yaml").sensor


def pixel_grid(sensor, n=1000):
    """n x n pixels spread over the whole image (and a little beyond)."""
    u = np.linspace(-0.5, sensor.image_width - 0.5, n)
    v = np.linspace(-0.5, sensor.image_height - 0.5, n)
    uu, vv = np.meshgrid(u, v)
    return np.column_stack([uu.ravel(), vv.ravel()])


def point_grid(n=1000):
    """n x n sensor-frame points: bearings all around, distances 0.5..300,
    heights -100..200 (many visible, some not)."""
    rng = np.random.default_rng(7)
    bearing = rng.uniform(-math.pi, math.pi, n * n)
    distance = np.repeat(np.linspace(0.5, 300.0, n), n)
    height = np.tile(np.linspace(-100.0, 200.0, n), n)
    return np.column_stack([distance * np.cos(bearing), distance * np.sin(bearing), height])


def same(a, b):
    """Equal, NaN where the other is NaN."""
    return np.array_equal(a, b, equal_nan=True)


def test_hand_values():
    # tests/sensor/geometry_test.cc [hand_value]: sphere r 1 at d 2, f 100 px;
    # the mirror point at 30 degrees seen at D = 10.5 by hand.
    phi = math.pi / 6
    ps, pz = math.sin(phi), 2 - math.cos(phi)
    length = math.hypot(ps, pz)
    vs, vz = ps / length, pz / length
    ns, nz = math.sin(phi), -math.cos(phi)
    dot = vs * ns + vz * nz
    ds, dz = vs - 2 * dot * ns, vz - 2 * dot * nz
    D = 10.5
    Z = pz + (D - ps) * dz / ds
    expected_radius = 100 * ps / pz
    assert Z == pytest.approx(0.0465633, abs=1e-6)
    assert expected_radius == pytest.approx(44.0927, abs=1e-4)
    s = pt.sphere_sensor(200, 200, 100, 99.5, 99.5, 1.0, 1.0, 2.0)
    eps = 500 * np.finfo(float).eps
    assert s.image_radius(D, Z) == pytest.approx(expected_radius, rel=eps)
    assert s.inverse_image_radius(expected_radius, Z) == pytest.approx(D, rel=eps)
    px = s.project([0.0, D, Z])
    assert px.shape == (2,)
    assert px[0] == pytest.approx(99.5, abs=1e-9)
    assert px[1] == pytest.approx(99.5 + expected_radius, rel=eps)
    # [limb]: the paper's real sensor, about 202 px.
    real = pt.sphere_sensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1)
    c = 4.9 / 15.1
    assert real.limb_radius == pytest.approx(590 * 4.9 * math.sqrt(1 - c * c) / (15.1 - 4.9 * c), rel=1e-12)


def test_visibility_is_nan():
    # tests/sensor/geometry_test.cc [visibility]: points the mirror cannot show.
    s = pt.sphere_sensor(640, 480, 590, 319.5, 239.5, 1.0, 4.9, 15.1)
    hidden = np.array([[0, 0, -50], [0, 0, 500], [1, 0, 500], [0.5, 0.5, 15.1], [30, 0, 300],
                       [np.nan, 0, 10], [np.inf, 0, 10]], dtype=float)
    assert np.isnan(s.project(hidden)).all()
    shown = s.project(np.array([[100.0, 40.0, z] for z in (-30.0, 0.0, 60.0)]))
    assert np.isfinite(shown).all()
    azimuth = np.arctan2(shown[:, 1] - 239.5, shown[:, 0] - 319.5)
    np.testing.assert_allclose(azimuth, math.atan2(40, 100), atol=1e-12)
    assert s.image_radius(100.0, 60.0) > s.image_radius(100.0, -30.0)
    assert math.isnan(s.image_radius(30.0, 300.0 + 15.1))


def test_project_grid_matches_single_points(sensor):
    points = point_grid()
    pixels = sensor.project(points)
    assert pixels.shape == (points.shape[0], 2) and pixels.dtype == np.float64
    visible = np.isfinite(pixels[:, 0])
    assert 0.2 < visible.mean() < 0.99  # both kinds on the grid
    assert np.array_equal(np.isfinite(pixels[:, 1]), visible)
    # Every 997th point through the single-point call, and the serial loop.
    for i in range(0, len(points), 997):
        assert same(sensor.project(points[i]), pixels[i])
    assert same(sensor.project(points, num_threads=1), pixels)
    # Non-contiguous and float32 input are converted.
    assert same(sensor.project(np.asfortranarray(points)), pixels)


def test_backproject_grid_matches_single_points(sensor):
    pixels = pixel_grid(sensor)
    origins, directions = sensor.backproject(pixels)
    assert origins.shape == directions.shape == (10**6, 3)
    seen = np.isfinite(origins[:, 0])
    # The mirror's disc (limb radius about 157 px) inside the 500 x 500 image.
    r = np.hypot(pixels[:, 0] - sensor.cx, pixels[:, 1] - sensor.cy)
    assert seen[r < 0.999 * sensor.limb_radius].all()
    assert not seen[r > 1.001 * sensor.limb_radius].any()
    np.testing.assert_allclose(np.linalg.norm(directions[seen], axis=1), 1.0, atol=1e-12)
    for i in range(0, len(pixels), 997):
        o, d = sensor.backproject(pixels[i])
        assert same(o, origins[i]) and same(d, directions[i])


def test_round_trip(sensor):
    pixels = pixel_grid(sensor)
    origins, directions = sensor.backproject(pixels)
    seen = np.isfinite(origins[:, 0])
    # A point 100 units along each ray projects back to its pixel.
    points = origins[seen] + 100.0 * directions[seen]
    back = sensor.project(points)
    ok = np.isfinite(back[:, 0])
    assert ok.mean() > 0.99  # the few others lie behind the mirror's rim of visibility
    err = np.abs(back[ok] - pixels[seen][ok]).max()
    assert err < 1e-6, err
    # E(D, Z) and its inverse on a 1000 x 1000 grid, broadcast.
    D = np.linspace(5, 300, 1000)[:, None]
    Z = np.linspace(-50, 100, 1000)[None, :]
    radius = sensor.image_radius(D, Z)
    assert radius.shape == (1000, 1000)
    fin = np.isfinite(radius)
    assert fin.mean() > 0.9
    D_back = sensor.inverse_image_radius(radius, np.broadcast_to(Z, radius.shape))
    np.testing.assert_allclose(D_back[fin], np.broadcast_to(D, radius.shape)[fin], rtol=1e-9)


def test_shapes_are_checked(sensor):
    with pytest.raises(ValueError, match=r"points: expected an array of shape \(N, 3\)"):
        sensor.project(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"pixels: expected an array of shape \(N, 2\)"):
        sensor.backproject(np.zeros(3))
    assert sensor.project(np.zeros((0, 3))).shape == (0, 2)


def test_calibration_file_round_trip(sensor, tmp_path):
    calib = pt.read_calibration(SOURCE_DIR / "calib" / "paper-synthetic.yaml")
    calib.sensor.focal_px = 432.25
    calib.comment = "written from Python"
    pt.write_calibration(tmp_path / "c.yaml", calib)
    back = pt.read_calibration(str(tmp_path / "c.yaml"))
    assert back.sensor.params == calib.sensor.params
    assert (back.units, back.sensor.image_width, back.sensor.model) == (calib.units, 500, "sphere")
    # The comment is written, not read back.
    assert (tmp_path / "c.yaml").read_text().startswith("# written from Python\n")
    back.comment = calib.comment
    assert back.to_yaml() == calib.to_yaml()


def test_pickle_and_copy(sensor):
    import copy
    import pickle
    calib = pt.read_calibration(SOURCE_DIR / "calib" / "paper-synthetic.yaml")
    calib.extras = {"rms_px": 0.25}
    for c in (pickle.loads(pickle.dumps(calib)), copy.deepcopy(calib)):
        assert c.to_yaml() == calib.to_yaml() and c.lut_resolved == calib.lut_resolved
    s = pickle.loads(pickle.dumps(sensor))
    assert s.params == sensor.params and s.model == sensor.model
    assert same(s.project(point_grid(20)), sensor.project(point_grid(20)))


def test_asphere_terms_round_trip(sensor):
    """Model asphere: its terms are parameters, change the image, and pickle."""
    import pickle
    s = pickle.loads(pickle.dumps(sensor))
    s.model = "asphere"
    s.asphere_a4 = 0.02
    s.asphere_a6 = 0.01
    s.check()
    assert s.params["asphere_a4"] == 0.02 and s.params["asphere_a6"] == 0.01
    back = pickle.loads(pickle.dumps(s))
    assert back.model == "asphere" and back.params == s.params
    pts = point_grid(20)
    moved = s.project(pts) - sensor.project(pts)
    assert np.nanmax(np.abs(moved)) > 0.5
    assert same(back.project(pts), s.project(pts))


def test_speed_against_the_cpp_loop(sensor, capsys):
    """project on 10^6 points through numpy against the plain C++ loop (one
    thread, no numpy): measured and printed, not asserted."""
    import time
    points = point_grid()
    cpp_s, visible = pt._panotrack._time_project_loop(sensor, points)
    timings = {}
    for threads in (1, 0):
        best = math.inf
        for _ in range(2):
            t0 = time.perf_counter()
            out = sensor.project(points, num_threads=threads)
            best = min(best, time.perf_counter() - t0)
        timings[threads] = best
    assert np.isfinite(out[:, 0]).sum() == visible
    with capsys.disabled():
        print(f"\nproject 1e6 points: C++ loop {cpp_s * 1e3:.1f} ms; Python 1 thread {timings[1] * 1e3:.1f} ms "
              f"(ratio {timings[1] / cpp_s:.2f}); Python all threads {timings[0] * 1e3:.1f} ms "
              f"(ratio {timings[0] / cpp_s:.2f})")
