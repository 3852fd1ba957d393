#!/usr/bin/env bash
# Sourced by scripts/test: `strata view`'s tests need an X display. Without DISPLAY they start a
# private Xvfb; this installs it (Debian's xvfb) when it is missing.
set -euo pipefail

if [ -z "${DISPLAY:-}" ] && ! command -v Xvfb >/dev/null 2>&1; then
  echo "strata: no X display and no Xvfb; installing Xvfb (xvfb) for the viewer's tests" >&2
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq xvfb >/dev/null
fi
