#!/bin/sh
# Set up a loadpath checkout: system tools (as root on Debian), a virtual environment in .venv,
# and the package installed in editable mode with its test extras.
#
# System tools the tests drive (Debian 12 package names, see ../shared/docs/real-tools.md):
#   prusa-slicer (2.5), cura-engine (4.13), cura (CuraEngine's machine definitions and the Python
#   modules of Cura's plugin API), calculix-ccx (the FEA cross-check), chromium and chromium-driver
#   (the load-case editor's page, driven headless by selenium), python3-venv, and the X/GL
#   libraries the gmsh wheel's libgmsh.so links against even when headless.
# Without root (or off Debian) the tools are not installed; tests that need them then skip with a
# message, except in CI (CI=true), where they fail.
set -eu
cd "$(dirname "$0")/.."

APT_PACKAGES="prusa-slicer cura-engine cura calculix-ccx chromium chromium-driver python3-venv python3-pip \
libglu1-mesa libgl1 libxrender1 libxcursor1 libxfixes3 libxext6 libxft2 libfontconfig1 \
libxinerama1 libx11-6 libgomp1 libopengl0 libglx0 strace"  # strace: the service writes-nothing-outside test

need_apt() {
  for exe in prusa-slicer CuraEngine ccx chromium chromedriver; do
    command -v "$exe" >/dev/null 2>&1 || return 0
  done
  [ -d /usr/lib/cura/plugins/PostProcessingPlugin ] || return 0
  return 1
}

if [ "$(id -u)" = 0 ] && [ -f /etc/debian_version ] && command -v apt-get >/dev/null 2>&1; then
  if need_apt; then
    echo "setup: installing system tools with apt (about 2 minutes)" >&2
    apt-get update -q >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q $APT_PACKAGES >/dev/null
  fi
elif need_apt; then
  echo "setup: not root on Debian; install these for the full test suite: apt-get install $APT_PACKAGES" >&2
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv" >&2
  "$PY" -m venv .venv
fi
# Reinstall only when the package metadata changed.
stamp=.venv/.loadpath-setup-stamp
sig=$(cat setup.cfg pyproject.toml | cksum)
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$sig" ]; then
  echo "setup: installing loadpath and its test extras into .venv" >&2
  log=.venv/setup.log
  if ! { .venv/bin/python -m pip install -q --upgrade pip && .venv/bin/python -m pip install -q -e '.[test]'; } >"$log" 2>&1; then
    tail -n 20 "$log" >&2
    echo "setup: pip install failed; the whole log is in $log" >&2
    exit 1
  fi
  echo "$sig" > "$stamp"
fi

# Compile the swarm engine's kernels (numba) into the on-disk cache once, so neither the demo nor
# the test suite pays it inside a timed step.  About a minute of CPU on a clean clone; when they are
# cached already this is the check alone (a second or two).  Not fatal: the engine compiles on
# first use otherwise.
if ! .venv/bin/python - <<'PY'
import logging
import sys

logging.getLogger("loadpath.engines.swarm").setLevel(logging.ERROR)  # setup says it itself
from loadpath.engines.swarm import warmup
from loadpath.engines.swarm._jit import COMPILE_SECONDS

if not warmup.kernels_cached():
    print(f"setup: compiling the swarm engine (first time only, about {COMPILE_SECONDS} s)", file=sys.stderr)
    seconds = warmup.warm_up()
    print(f"setup: swarm engine compiled in {seconds:.0f} s", file=sys.stderr)

# the verdict's bead model: its point location and batch sampling (loadpath.fea.locate_kernel,
# loadpath.stiffness.sample_kernel), a few seconds
from types import SimpleNamespace

import numpy as np
from loadpath.fea.locate import TriangleLocator
from loadpath.fea.locate_kernel import locate_points
from loadpath.stiffness.sample_kernel import sample_batch

tri = TriangleLocator(np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]]))
locate_points(tri, np.zeros((1, 2)), 1e-9)
one = SimpleNamespace(start=np.zeros((1, 2)), end=np.array([[0.5, 0.0]]), volume=np.ones(1), height=np.ones(1))
sample_batch(one, np.zeros(1, dtype=np.int64), 0.1, tri, np.zeros(1, dtype=np.int64), np.zeros((1, 4)), np.zeros((3, 1)), 1)

# large splices' loops (loadpath.splice.kernels), a few seconds
from loadpath.splice import compiled

compiled.load()
PY
then
  echo "setup: compiling the swarm engine failed (see above); it will compile on first use" >&2
fi
