"""The Dask example (python/examples/dask_localize.py): parallel results equal
the sequential ones."""
import importlib.util

import numpy as np
import pytest

import panotrack as pt
from conftest import SOURCE_DIR

dask = pytest.importorskip("dask")


def example():
    spec = importlib.util.spec_from_file_location("dask_localize", SOURCE_DIR / "python" / "examples" / "dask_localize.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_localize_all_equals_one_by_one(sequence):
    calib, room = pt.read_calibration(sequence / "calib.yaml"), pt.read_map(sequence / "map.yaml")
    inputs = [sequence / "video.mp4", sequence / "frames"]
    results = example().localize_all(inputs, calib, room, workers=2)
    assert len(results) == 2
    for video, (rows, summary) in zip(inputs, results):
        assert summary["end"] == "done" and summary["n_ok"] == 66
        alone = pt.localize_video(video, sequence / "calib.yaml", sequence / "map.yaml")
        for name in rows.dtype.names:
            assert np.array_equal(rows[name], alone[name], equal_nan=rows.dtype[name].kind == "f"), name


def test_project_chunked_equals_project():
    sensor = pt.read_calibration(SOURCE_DIR / "calib" / "paper-synthetic.yaml").sensor
    points = np.random.default_rng(3).uniform([-200, -200, -50], [200, 200, 150], (300_000, 3))
    chunked = example().project_chunked(sensor, points, chunk=70_000)
    assert chunked.npartitions == 5
    assert np.array_equal(chunked.compute(scheduler="threads"), sensor.project(points), equal_nan=True)
