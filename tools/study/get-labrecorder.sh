#!/usr/bin/env bash
# Builds LabRecorderCLI (the command-line half of LSL's LabRecorder, which writes XDF files)
# against the liblsl that `cargo build` made for vlf's `lsl` feature, so that
# tools/study/labrecorder_check.py can record vlf's outlets into an XDF file as a lab would.
#   bash tools/study/get-labrecorder.sh [LABRECORDER_SOURCE_DIR]
# Without a source directory it clones https://github.com/labstreaminglayer/App-LabRecorder.
# Needs cmake and a C++20 compiler (g++ 12 does). Writes target/labrecorder/LabRecorderCLI.
# LabRecorder's CMakeLists asks for CMake 3.28 and liblsl 1.17's install helpers; neither is
# needed for the CLI, so the copy built here lowers the one and leaves the others out.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=target/labrecorder
src=${1:-}
lsl_root=$(ls -d target/release/build/lsl-sys-*/out 2>/dev/null | while read -r d; do
  [ -f "$d/share/LSL/LSLConfig.cmake" ] && echo "$d"; done | head -1)
if [ -z "$lsl_root" ]; then
  echo "get-labrecorder.sh: no liblsl from vlf's build under target/release/build/lsl-sys-*/out:" \
    "run \`cargo build --release\` first (the lsl feature is on by default)" >&2
  exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ -z "$src" ]; then
  git clone --depth 1 https://github.com/labstreaminglayer/App-LabRecorder "$work/src"
else
  cp -r "$src" "$work/src"
fi
cd "$work/src"
sed -i 's/cmake_minimum_required(VERSION 3\.2[0-9])/cmake_minimum_required(VERSION 3.25)/' \
  CMakeLists.txt xdfwriter/CMakeLists.txt
sed -i 's/^LSL_configure_rpath()/# LSL_configure_rpath() (liblsl 1.17 only)/' CMakeLists.txt
# the install and packaging rules need liblsl 1.17's CMake helpers; the CLI needs none of them
python3 - <<'PY'
s = open("CMakeLists.txt").read()
open("CMakeLists.txt", "w").write(s[: s.index("include(GNUInstallDirs)")])
PY
cmake -S . -B build -DLABRECORDER_BUILD_GUI=OFF -DLSL_FETCH_IF_MISSING=OFF \
  -DLSL_INSTALL_ROOT="$OLDPWD/$lsl_root" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target LabRecorderCLI -j"$(nproc)"
cd "$OLDPWD"
mkdir -p "$out"
cp "$work/src/build/LabRecorderCLI" "$out/"
cp "$lsl_root"/lib/liblsl.so* "$out/"
echo "LabRecorderCLI in $out (run it with LD_LIBRARY_PATH=$out)"
