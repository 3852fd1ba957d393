#!/usr/bin/env bash
# Sourced by scripts/strata and scripts/test: makes sure a Vulkan driver is present. Without one
# (no GPU driver's ICD file), installs Mesa's software Vulkan driver, lavapipe.
set -euo pipefail

have_vulkan_icd() {
  local d
  for d in /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
    if compgen -G "$d/*.json" >/dev/null; then return 0; fi
  done
  [ -n "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ]
}

if ! have_vulkan_icd; then
  echo "strata: no Vulkan driver found; installing Mesa's software driver (mesa-vulkan-drivers)" >&2
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq mesa-vulkan-drivers >/dev/null
fi
# Mesa's software driver warns when this is unset.
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
