#!/usr/bin/env bash
# Makes sure a wgpu adapter can be found: a real GPU's Vulkan driver, or else Mesa's software
# Vulkan (lavapipe). Installs mesa-vulkan-drivers with apt-get when no Vulkan driver is present.
set -euo pipefail
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
if have_icd; then
  exit 0
fi
if ! command -v apt-get >/dev/null; then
  echo "tools/setup.sh: no Vulkan driver found and no apt-get; install your distribution's Mesa Vulkan drivers (lavapipe) or a GPU driver" >&2
  exit 1
fi
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
echo "tools/setup.sh: no Vulkan driver found; installing mesa-vulkan-drivers (software Vulkan, lavapipe)" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
have_icd || { echo "tools/setup.sh: still no Vulkan driver after installing mesa-vulkan-drivers" >&2; exit 1; }
