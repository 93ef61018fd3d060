#!/usr/bin/env bash
# Installs what grainflow needs on a fresh Debian machine: pkg-config and the HDF5 C
# library (libhdf5-dev), found by the hdf5 crate through pkg-config, and the DejaVu Sans
# font (fonts-dejavu-core) that `grainflow plot` draws its text with. Needs root for
# apt-get; does nothing when both are already there.
set -euo pipefail
if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found; install Rust (rustup) first" >&2
  exit 1
fi
if ! (command -v pkg-config >/dev/null 2>&1 && pkg-config --exists hdf5); then
  echo "setup: installing pkg-config and libhdf5-dev" >&2
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq pkg-config libhdf5-dev >/dev/null
fi
FONT=/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf
if [ ! -f "$FONT" ]; then
  echo "setup: installing fonts-dejavu-core ($FONT, for grainflow plot)" >&2
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq fonts-dejavu-core >/dev/null
fi
