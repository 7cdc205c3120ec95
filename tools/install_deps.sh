#!/usr/bin/env bash
# Installs the Debian 12 packages autonomsim needs to build, test and run, then the test-only
# Node.js readers (package.json: `npm ci` at the repository root, into node_modules/). Idempotent:
# packages already present are not touched, apt is not called at all when nothing is missing, and
# npm only when node_modules is missing or older than package-lock.json.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ninja-build pkg-config
  libbox2d-dev libeigen3-dev libopencv-dev
  mosquitto mosquitto-clients libmosquitto-dev
  libyaml-cpp-dev nlohmann-json3-dev libssl-dev libcli11-dev libfmt-dev libspdlog-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  openssl  # the TLS test makes its certificates with it
  parallel  # GNU parallel: the sweep test runs docs/sweeps.md#beyond-one-machine's recipe
  clang libclang-rt-14-dev  # tools/fuzz.sh: libFuzzer and clang's sanitizer runtimes
  clang-format  # .ci/run checks every C++ file against .clang-format before the builds
  chromium  # the replay report's browser test loads it in headless chromium
  gnuplot-nox  # draws a sweep's plots (pngcairo)
  # the Python module (python/, docs/python.md): pybind11 and the headers of Debian's python3; its
  # tests (pytest) and docs example (numpy, pandas, matplotlib); python3-venv: pip install into a
  # virtual environment
  pybind11-dev python3-pybind11 python3-dev python3-numpy python3-pandas python3-matplotlib
  python3-pytest python3-venv python3-setuptools python3-pip
  python3-paho-mqtt  # the real-time test's stand-in of the lab's vtl.py (tools/tests/vtl_standin.py)
  cyclonedds-tools  # ddsperf: bench/dds_vs_cyclone.sh measures real Cyclone DDS against the model
  # the GL camera backend and 3D views: EGL and OpenGL ES headers (glvnd), and Mesa's EGL driver
  # with llvmpipe, which renders without a GPU or a display (EGL_PLATFORM_SURFACELESS_MESA)
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
  libzstd-dev zlib1g-dev  # sim/mcap: zstd chunks and CRC-32 (zlib's crc32) in MCAP recordings
  # track.png and the report's pictures: written with libpng and libjpeg directly (OpenCV's
  # imgcodecs loads some 130 libraries before main; sim/results/image_encoding.h)
  libpng-dev libjpeg-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
# Debian's Node.js, for the test readers (tools/tests/mcap_check.mjs), only where there is no
# `node` at all: a newer one installed otherwise (nodesource, nvm) is used as it is.
if ! command -v node >/dev/null; then
  missing+=(nodejs npm)
fi

if [ ${#missing[@]} -gt 0 ]; then
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "install_deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
    sudo_cmd=(sudo)
  fi
  echo "install_deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The test readers, pinned by package-lock.json (the ctest Mcap.node_reader, label node, uses
# them). node_modules/ is remade when missing or older than the lock file.
if [ ! -d node_modules ] || [ package-lock.json -nt node_modules ]; then
  echo "install_deps: npm ci (the test readers in package.json)"
  npm ci --no-audit --no-fund --ignore-scripts  # none is needed: the zstd decoder is prebuilt wasm
  touch node_modules  # its time marks this install, for the test above
fi
