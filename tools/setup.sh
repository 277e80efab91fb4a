#!/usr/bin/env bash
# Installs what is missing, with apt-get (and sudo when not root) and pip, for one of README's
# two commands:
#   bash tools/setup.sh demo   what `vlf demo` needs to build and run: a wgpu adapter (a real
#                              GPU's Vulkan driver, or else Mesa's software Vulkan, lavapipe),
#                              libudev for gamepads (gilrs), cmake (the `lsl` crate builds
#                              liblsl, src/study/lsl.rs), and Open MPI + libclang, because
#                              the demo and the tests share one build (`--features mpi`, the
#                              CAVE cluster), so the test command does not rebuild the crate
#   bash tools/setup.sh test   the demo's, and what only the tests use: Xvfb, ImageMagick's
#                              `import` and xdotool (the windowed CAVE test), the OpenXR loader
#                              (tests/xr.rs), Mitsuba 3 + numpy (the independent reference,
#                              tests/mitsuba.rs), pygltflib (tests/gltf.rs), pylsl (the LSL
#                              outlets read back, tests/study.rs; its wheel brings liblsl) and
#                              pyarrow (the session log's Parquet read back, tests/study.rs)
#                              and ffmpeg (`vlf replay --video`, read back with ffprobe there)
set -euo pipefail
mode=${1:-test}
case "$mode" in
  demo | test) ;;
  *) echo "tools/setup.sh: unknown mode '$mode': use 'demo' or 'test'" >&2; exit 2 ;;
esac

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

pip_install() { # module-to-import package...
  local module=$1
  shift
  python3 -c "import $module" 2>/dev/null && return 0
  command -v python3 >/dev/null || { echo "tools/setup.sh: no python3 (3.11 or newer is needed by the tests)" >&2; exit 1; }
  echo "tools/setup.sh: installing $* with pip" >&2
  python3 -m pip install -q "$@" 2>/dev/null \
    || python3 -m pip install -q --break-system-packages "$@" \
    || { echo "tools/setup.sh: pip could not install $*; install them for $(command -v python3)" >&2; exit 1; }
}

missing=()
# the demo: an adapter, the build's system libraries
have_icd || missing+=(mesa-vulkan-drivers libvulkan1)
{ command -v pkg-config >/dev/null && pkg-config --exists libudev; } || missing+=(pkg-config libudev-dev)
{ command -v mpirun >/dev/null && command -v mpicc >/dev/null; } || missing+=(openmpi-bin libopenmpi-dev)
{ ldconfig -p 2>/dev/null | grep -q 'libclang[-.0-9]*\.so'; } || missing+=(libclang-dev)
command -v cmake >/dev/null || missing+=(cmake)
if [ "$mode" = test ]; then
  command -v Xvfb >/dev/null || missing+=(xvfb)
  command -v import >/dev/null || missing+=(imagemagick)
  command -v xdotool >/dev/null || missing+=(xdotool)
  [ -e /usr/lib/x86_64-linux-gnu/libopenxr_loader.so.1 ] || [ -e /usr/lib/libopenxr_loader.so.1 ] || missing+=(libopenxr-loader1)
  { command -v ffmpeg >/dev/null && command -v ffprobe >/dev/null; } || missing+=(ffmpeg)
fi
if [ ${#missing[@]} != 0 ]; then
  if ! command -v apt-get >/dev/null; then
    echo "tools/setup.sh: missing ${missing[*]} and no apt-get; install them (a Vulkan driver or Mesa's lavapipe, libudev, cmake, Open MPI, libclang; for the tests Xvfb, ImageMagick, xdotool, the OpenXR loader, ffmpeg) with your distribution's tools" >&2
    exit 1
  fi
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  echo "tools/setup.sh ($mode): installing ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
  have_icd || { echo "tools/setup.sh: still no Vulkan driver after installing mesa-vulkan-drivers" >&2; exit 1; }
fi
# LLVM 16 or newer lets Mitsuba's references use its fast llvm_ad_rgb variant (Debian 12:
# libllvm19); without it they render with scalar_rgb, slower. Optional: not every distribution
# has the package.
if [ "$mode" = test ] && command -v apt-get >/dev/null \
  && ! ldconfig -p 2>/dev/null | grep -qE 'libLLVM(-(1[6-9]|[2-9][0-9])|\.so\.(1[6-9]|[2-9][0-9]))'; then
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libllvm19 >/dev/null 2>&1 \
    || echo "tools/setup.sh: no libllvm19 (LLVM >= 16): Mitsuba's references render with scalar_rgb, slower" >&2
fi
if [ "$mode" = test ]; then
  pip_install "mitsuba, numpy" mitsuba numpy
  pip_install pygltflib pygltflib
  pip_install pylsl pylsl
  pip_install pyarrow pyarrow
fi
# tools/test.sh lints the build with clippy-driver (rustup's `clippy` component)
if [ "$mode" = test ] && ! command -v clippy-driver >/dev/null && command -v rustup >/dev/null; then
  echo "tools/setup.sh (test): adding rustup's clippy component" >&2
  rustup component add clippy
fi
