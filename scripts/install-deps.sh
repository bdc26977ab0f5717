#!/usr/bin/env bash
# Installs the Debian packages BTF Studio builds against, only those missing.
# Idempotent; fast (one dpkg-query) when everything is present; uses sudo when not root.
set -euo pipefail
PKGS=(cmake ninja-build g++ make pkg-config libglfw3-dev libglm-dev libimgui-dev libembree-dev
  libopenmesh-dev libopenimageio-dev libosd-dev libgtest-dev libbenchmark-dev libeigen3-dev
  libtbb-dev libcli11-dev nlohmann-json3-dev xvfb xauth libgl1-mesa-dri mesa-utils libegl1
  libegl-mesa0 fonts-dejavu-core libopenmpi-dev openmpi-bin libzip-dev libpolyclipping-dev
  pybind11-dev python3-dev python3-numpy python3-pytest python3-venv libllvm19 zlib1g-dev)
# `install-deps.sh fuzz`: also clang and its libFuzzer runtime (make fuzz only).
if [ "${1:-}" = "fuzz" ]; then PKGS+=(clang-14 libclang-rt-14-dev); fi
missing=()
for p in "${PKGS[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "install-deps: installing missing Debian packages: ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install-deps: not root and no sudo; install as root: apt-get install ${missing[*]}" >&2
    exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
