"""calibrate() runs the library's Calibrate as panocalib does: the same fit,
standard deviations and per-image RMS as the file panocalib writes."""
import pytest

import panotrack as pt
from conftest import SOURCE_DIR, program, run


def test_calibrate_matches_panocalib(targets, tmp_path):
    out = tmp_path / "panocalib.yaml"
    r = run([program("panocalib"), "calibrate", str(targets / "targets.yaml"), "-o", str(out)])
    assert r.returncode == 0, r.stderr
    expected = pt.read_calibration(out)

    result = pt.calibrate(targets / "targets.yaml")
    calib = result.calibration
    assert result.poses_known and result.not_found_files == []
    for name, value in expected.sensor.params.items():
        assert calib.sensor.params[name] == pytest.approx(value, rel=1e-9, abs=1e-12), name
    extras = expected.extras
    assert result.rms_px == pytest.approx(extras["rms_px"], rel=1e-9)
    assert result.rms_px == pytest.approx(0.0733, abs=0.002)  # measured (noise 2 grey levels)
    # The figure evaluate reproduces; the fit's own and the raw-corner one beside it.
    assert result.fit_rms_px == pytest.approx(result.rms_px, rel=0.1)
    assert result.rms_raw_px > result.rms_px
    assert list(result.image_rms) == [f"cal_{i:03d}.png" for i in range(8)]
    for i, v in enumerate(result.image_rms.values()):
        assert v == pytest.approx(expected.images[f"cal_{i:03d}.png"]["rms_px"], rel=1e-9)
    assert " calibrate " in expected.command_line and expected.software.startswith("panotrack ")
    import pickle
    again = pickle.loads(pickle.dumps(expected))
    assert again.images == expected.images and again.command_line == expected.command_line
    assert set(result.parameters) == {"focal_px", "cx", "cy", "aspect", "mirror_radius", "mirror_distance",
                                      "azimuth_offset"}
    for name, p in result.parameters.items():
        assert p.name == name and not p.fixed
        assert p.stddev == pytest.approx(extras[name + "_std"], rel=1e-9), name
    assert result.parameters["focal_px"].value == calib.sensor.focal_px
    # The truth the images were rendered with, within 2 standard deviations.
    truth = pt.read_calibration(SOURCE_DIR / "calib" / "paper-real.yaml").sensor
    focal = result.parameters["focal_px"]
    assert abs(focal.value - truth.focal_px) < 2 * focal.stddev
    assert f"RMS reprojection error {result.rms_px:.4f} px over 8 boards" in result.summary()
    assert f"the fit's own {result.fit_rms_px:.4f} px" in result.summary()
    assert "chosen: sphere" in result.summary()

    # Written as panocalib writes it, with the E(D,Z) table beside it.
    result.write(tmp_path / "py.yaml", lut=tmp_path / "py_lut.bin", report=tmp_path / "report.png")
    written = pt.read_calibration(tmp_path / "py.yaml")
    assert (tmp_path / "py_lut.bin").exists() and (tmp_path / "report.png").exists()
    assert written.lut_resolved == str(tmp_path / "py_lut.bin")
    assert written.sensor.params == expected.sensor.params


def test_calibrate_errors(targets, tmp_path):
    with pytest.raises(pt.Error) as e:
        pt.calibrate(targets / "targets.yaml", model="cylinder")
    assert str(e.value) == "model: expected sphere, conic, asphere, unified or auto, got 'cylinder'"
    with pytest.raises(pt.Error) as e:
        pt.calibrate(tmp_path / "missing.yaml")
    assert str(e.value) == f"{tmp_path / 'missing.yaml'}: cannot open: No such file or directory"
    with pytest.raises(TypeError):
        pt.calibrate(targets / "targets.yaml", unknown_option=1)
