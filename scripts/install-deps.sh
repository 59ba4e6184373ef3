#!/usr/bin/env bash
# Installs the build and run-time dependencies from Debian's packages.
# Run as root (CI does). Idempotent: packages already present are kept.
set -euo pipefail
pkgs=(build-essential cmake pkg-config
      libopencv-dev libopencv-contrib-dev
      libeigen3-dev libceres-dev libyaml-cpp-dev libcli11-dev
      catch2 libbenchmark-dev ffmpeg libavcodec-dev libavformat-dev libavutil-dev
      help2man dpkg-dev nlohmann-json3-dev
      pybind11-dev python3-dev python3-numpy python3-pytest python3-venv python3-dask python3-distributed)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  echo "install-deps: installing ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
