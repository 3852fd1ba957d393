#!/usr/bin/env bash
# Sourced by scripts/test: `strata view`'s tests need an X display. Without DISPLAY they start a
# private Xvfb; this installs it (Debian's xvfb) when it is missing.
set -euo pipefail

# The X libraries winit loads at run time (it links none of them).
x_libraries_missing() {
  local lib known
  known="$(ldconfig -p)"
  for lib in libX11.so.6 libXcursor.so.1 libXrandr.so.2 libXi.so.6 libxkbcommon-x11.so.0; do
    if ! grep -qF "$lib" <<<"$known"; then return 0; fi
  done
  return 1
}

packages=()
if [ -z "${DISPLAY:-}" ] && ! command -v Xvfb >/dev/null 2>&1; then packages+=(xvfb); fi
if x_libraries_missing; then packages+=(libx11-6 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0); fi
if [ ${#packages[@]} -gt 0 ]; then
  echo "strata: installing ${packages[*]} for the viewer's tests" >&2
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq "${packages[@]}" >/dev/null
fi
