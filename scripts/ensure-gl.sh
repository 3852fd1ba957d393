#!/usr/bin/env bash
# Sourced by scripts/test: the backends test opens wgpu's GL backend headless through EGL (Mesa's
# llvmpipe without a GPU). This installs Mesa's EGL and GL drivers when they are missing.
set -euo pipefail

gl_libraries_missing() {
  local known
  known="$(ldconfig -p)"
  grep -qF libEGL.so.1 <<<"$known" || return 0
  grep -qF libEGL_mesa.so.0 <<<"$known" || return 0
  [ -e /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so ] || compgen -G "/usr/lib/*/dri/swrast_dri.so" >/dev/null || return 0
  return 1
}

if gl_libraries_missing; then
  echo "strata: installing Mesa's EGL and GL drivers (libegl1 libegl-mesa0 libgl1-mesa-dri) for the GL backend's tests" >&2
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq libegl1 libegl-mesa0 libgl1-mesa-dri >/dev/null
fi
