#!/usr/bin/env bash
# Installs the build and run-time dependencies from Debian's packages.
# Run as root (CI does). Idempotent: packages already present are kept.
set -euo pipefail
pkgs=(build-essential cmake pkg-config
      libopencv-dev libopencv-contrib-dev
      libeigen3-dev libceres-dev libyaml-cpp-dev libcli11-dev
      catch2 libbenchmark-dev ffmpeg libavcodec-dev libavformat-dev libavutil-dev
      help2man dpkg-dev nlohmann-json3-dev
      pybind11-dev python3-dev python3-numpy python3-pytest python3-venv python3-dask python3-distributed
      python3-pip python3-opencv)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
if [ "${#missing[@]}" -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# The Python packages that read and write robot recordings (panotrack.bag:
# ROS 1 and ROS 2 bags, MCAP files), which Debian does not package: from PyPI
# into the system's interpreter, as the tests run with it. numpy stays
# Debian's 1.x: the module built with Debian's pybind11 2.10 refuses numpy 2.
if ! /usr/bin/python3 -c "import rosbags.highlevel, mcap.writer, mcap_ros2.decoder" 2>/dev/null; then
  echo "install-deps: installing rosbags, mcap and mcap-ros2-support from PyPI" >&2
  $SUDO /usr/bin/python3 -m pip install -q --break-system-packages --disable-pip-version-check \
    "rosbags>=0.11" "mcap>=1.1" "mcap-ros2-support>=0.5" "numpy<2"
fi
# The run viewer (panotrack.viewer): Rerun's SDK 0.22.1, its last release
# that runs with numpy 1.x (0.23 on require numpy 2), and a pyarrow that
# still does (the newest refuses numpy 1.x at import; 19.0.1 runs with it).
if ! /usr/bin/python3 -c "import rerun, pyarrow; assert rerun.__version__ == '0.22.1'" 2>/dev/null; then
  echo "install-deps: installing rerun-sdk 0.22.1 from PyPI" >&2
  $SUDO /usr/bin/python3 -m pip install -q --break-system-packages --disable-pip-version-check \
    "rerun-sdk==0.22.1" "pyarrow<20" "numpy<2"
fi
