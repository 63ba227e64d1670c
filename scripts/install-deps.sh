#!/usr/bin/env bash
# Installs the Debian 12 packages abrad needs to build and test. Run as root (or with sudo).
# Skips apt entirely when everything is already present, so repeated runs are fast.
set -euo pipefail
packages=(cmake g++ make ccache pkg-config libsqlite3-dev libglm-dev libgtest-dev libgmock-dev
          libcli11-dev libtbb-dev libcgal-dev libassimp-dev libtomlplusplus-dev libbenchmark-dev gnuplot-nox
          libopenimageio-dev openimageio-tools libtinygltf-dev nlohmann-json3-dev libexpat1-dev fonts-dejavu-core
          povray povray-includes libopenmesh-dev
          python3-meshio  # the export tests read PLY with meshio (Debian's /usr/bin/python3)
          openmpi-bin libopenmpi-dev  # the bake shared over MPI ranks (mpirun; ABRAD_MPI)
          clang-format clang-tidy  # the style tests (Debian 12: version 14)
          chromium)  # the report's browser test (headless, WebGL through SwiftShader)
# Node.js and npm for the export tests' readers (tests/export/package.json: the Khronos glTF
# validator, three.js), from Debian unless a node and npm are already on the PATH (NodeSource)
command -v node >/dev/null && command -v npm >/dev/null || packages+=(nodejs npm)
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
    echo "install-deps: installing ${missing[*]}" >&2
    sudo_cmd=()
    [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
    "${sudo_cmd[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
