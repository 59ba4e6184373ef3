"""Shared fixtures: the build's programs, the source tree, and inputs rendered
once per session with panosim (a short sequence, chessboard images)."""
import os
import pathlib
import subprocess

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("PANO_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


def program(name):
    """The path of a program of the build (PANO_BIN_DIR); skips without it."""
    bin_dir = os.environ.get("PANO_BIN_DIR")
    if not bin_dir:
        pytest.skip("PANO_BIN_DIR is not set (run from ctest, or set it to the build's bin/)")
    path = pathlib.Path(bin_dir) / name
    if not path.exists():
        pytest.skip(f"{path} is not built")
    return str(path)


def run(argv, **kwargs):
    """Runs a program; returns the CompletedProcess (text output)."""
    return subprocess.run(argv, capture_output=True, text=True, **kwargs)


@pytest.fixture(scope="session")
def sequence(tmp_path_factory):
    """panosim sequence --preset paper-synthetic (66 frames of 500 x 500 px):
    the folder with video.mp4, frames/, calib.yaml, map.yaml, gt.csv, case.yaml."""
    out = tmp_path_factory.mktemp("seq") / "paper-synthetic"
    r = run([program("panosim"), "sequence", "--preset", "paper-synthetic", "--frames", "-q", "-o", str(out)])
    assert r.returncode == 0, r.stderr
    return out


@pytest.fixture(scope="session")
def targets(tmp_path_factory):
    """panosim targets: 8 chessboard images of the paper's real sensor (9 x 6
    corners, 3 cm squares) with known poses; the folder."""
    out = tmp_path_factory.mktemp("targets") / "t"
    r = run([program("panosim"), "targets", "--calib", str(SOURCE_DIR / "calib" / "paper-real.yaml"),
             "--board", "9,6,3", "--auto", "8", "--noise", "2", "--seed", "3", "-q", "-o", str(out)])
    assert r.returncode == 0, r.stderr
    return out
