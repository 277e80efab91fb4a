#!/usr/bin/env bash
# Makes sure the tests can run: a wgpu adapter (a real GPU's Vulkan driver, or else Mesa's
# software Vulkan, lavapipe), a virtual display and a screenshot tool for the windowed CAVE
# test (Xvfb, ImageMagick's import), libudev for gamepads (gilrs), Open MPI and libclang for the
# CAVE cluster (`--features mpi`: mpirun, the MPI headers, bindgen's libclang; tests/cluster.rs),
# Mitsuba 3 + numpy for the independent reference (tests/mitsuba.rs), pygltflib for
# tests/gltf.rs. Installs what is missing with apt-get and pip.
set -euo pipefail
# Python packages first: they do not depend on the system packages below
if ! python3 -c 'import mitsuba, numpy' 2>/dev/null; then
  command -v python3 >/dev/null || { echo "tools/setup.sh: no python3 (3.11 or newer is needed for tests/mitsuba.rs)" >&2; exit 1; }
  echo "tools/setup.sh: installing Mitsuba 3 and numpy with pip" >&2
  python3 -m pip install -q mitsuba numpy 2>/dev/null \
    || python3 -m pip install -q --break-system-packages mitsuba numpy \
    || { echo "tools/setup.sh: pip could not install mitsuba numpy; install them for $(command -v python3)" >&2; exit 1; }
fi
# pygltflib: the independent glTF writer of tests/gltf.rs (tools/obj2gltf.py)
if ! python3 -c 'import pygltflib' 2>/dev/null; then
  echo "tools/setup.sh: installing pygltflib with pip" >&2
  python3 -m pip install -q pygltflib 2>/dev/null \
    || python3 -m pip install -q --break-system-packages pygltflib \
    || { echo "tools/setup.sh: pip could not install pygltflib; install it for $(command -v python3)" >&2; exit 1; }
fi
have_icd() {
  local icd found=""
  for icd in /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json /usr/local/share/vulkan/icd.d/*.json; do
    [ -e "$icd" ] && found=yes
  done
  [ -n "$found" ] || return 1
  local libs
  libs=$(ldconfig -p 2>/dev/null || true)
  [[ "$libs" == *libvulkan.so.1* ]]
}
missing=()
have_icd || missing+=(mesa-vulkan-drivers libvulkan1)
command -v Xvfb >/dev/null || missing+=(xvfb)
command -v import >/dev/null || missing+=(imagemagick)
command -v xdotool >/dev/null || missing+=(xdotool)
[ -e /usr/lib/x86_64-linux-gnu/libopenxr_loader.so.1 ] || [ -e /usr/lib/libopenxr_loader.so.1 ] || missing+=(libopenxr-loader1)
{ command -v pkg-config >/dev/null && pkg-config --exists libudev; } || missing+=(pkg-config libudev-dev)
# the CAVE cluster (--features mpi): Open MPI's mpirun and mpicc/headers, libclang for bindgen
{ command -v mpirun >/dev/null && command -v mpicc >/dev/null; } || missing+=(openmpi-bin libopenmpi-dev)
{ ldconfig -p 2>/dev/null | grep -q 'libclang[-.0-9]*\.so'; } || missing+=(libclang-dev)
if [ ${#missing[@]} = 0 ]; then
  exit 0
fi
if ! command -v apt-get >/dev/null; then
  echo "tools/setup.sh: missing ${missing[*]} and no apt-get; install them (a Vulkan driver or Mesa's lavapipe, Xvfb, ImageMagick, libudev) with your distribution's tools" >&2
  exit 1
fi
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
echo "tools/setup.sh: installing ${missing[*]}" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
have_icd || { echo "tools/setup.sh: still no Vulkan driver after installing mesa-vulkan-drivers" >&2; exit 1; }
