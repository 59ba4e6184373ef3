"""The Dask example (python/examples/dask_localize.py) on a local cluster of
worker processes: its table holds exactly panoloc's rows for every good
input, and a corrupt input is reported with panoloc's message without losing
the others."""
import importlib.util
import json
import shutil
import sys

import pytest

import panotrack as pt
from conftest import SOURCE_DIR, program, run
from test_localize import assert_rows_equal, read_pose_csv

pytest.importorskip("distributed")


EXAMPLE = SOURCE_DIR / "python" / "examples" / "dask_localize.py"


def example():
    spec = importlib.util.spec_from_file_location("dask_localize", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def inputs(sequence, tmp_path):
    """The video, a copy of it (elsewhere: no case.yaml beside it, so the
    first pose is searched for), the frames folder, and a truncated video."""
    copy = tmp_path / "copy.mp4"
    shutil.copy(sequence / "video.mp4", copy)
    corrupt = tmp_path / "corrupt.mp4"
    corrupt.write_bytes((sequence / "video.mp4").read_bytes()[:20000])
    return [str(sequence / "video.mp4"), str(copy), str(sequence / "frames"), str(corrupt)]


def panoloc_out_dir(sequence, inputs, out_dir):
    """panoloc --out-dir on the inputs: ({input: rows}, {input: error}) from
    its summary JSON, and the one-line messages it printed."""
    summary_json = out_dir / "summary.json"
    r = run([program("panoloc"), *inputs, "--calib", str(sequence / "calib.yaml"), "--map", str(sequence / "map.yaml"),
             "--out-dir", str(out_dir), "--summary-json", str(summary_json), "-q"])
    assert r.returncode == 1, r.stderr  # one input failed
    rows, errors = {}, {}
    for entry in json.loads(summary_json.read_text())["inputs"]:
        if entry["outputs"]:
            rows[entry["input"]] = read_pose_csv(entry["outputs"]["poses"])
        else:
            errors[entry["input"]] = entry["error"]
    return rows, errors, r.stderr.splitlines()


def test_example_on_local_cluster_equals_panoloc(sequence, inputs, tmp_path):
    expected, expected_errors, panoloc_messages = panoloc_out_dir(sequence, inputs, tmp_path / "panoloc")
    assert sorted(expected) == sorted(inputs[:3]) and list(expected_errors) == [inputs[3]]
    message = expected_errors[inputs[3]]
    assert message.startswith(inputs[3] + ": ") and f"panoloc: {message}" in panoloc_messages

    # The command line, on LocalCluster(n_workers=2, threads_per_worker=1,
    # processes=True); run as a program of its own, since the worker
    # processes are spawned from the main module (here, the example).
    missing = str(tmp_path / "missing.mp4")
    table_csv = tmp_path / "table.csv"
    r = run([sys.executable, str(EXAMPLE), "--local-workers", "2", "--calib", str(sequence / "calib.yaml"),
             "--map", str(sequence / "map.yaml"), "--out", str(table_csv), *inputs, missing])
    assert r.returncode == 1, r.stderr  # some failed
    assert r.stdout.splitlines() == [
        f"{inputs[0]}: 66 frames, 66 ok, 0 lost", f"{inputs[1]}: 66 frames, 66 ok, 0 lost",
        f"{inputs[2]}: 66 frames, 66 ok, 0 lost", f"{inputs[3]}: failed: {message}",
        f"{missing}: failed: {missing}: no such file", f"198 rows of 3 of 5 videos -> {table_csv}"]

    table = example().read_table(table_csv)
    assert table.dtype.names == ("video", *pt.POSE_DTYPE.names)
    assert list(dict.fromkeys(table["video"])) == inputs[:3]  # in the order given, the failed ones absent
    for video in inputs[:3]:
        rows = table[table["video"] == video]
        assert len(rows) == 66 and (rows["status"] == "ok").all()
        assert_rows_equal(rows, expected[video], tol=1e-9)  # every column
