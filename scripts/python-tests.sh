#!/usr/bin/env bash
# The Python package's tests (crates/omnikin-py): a fresh virtual environment in a temporary
# directory, `pip install ./crates/omnikin-py` (pip fetches maturin from PyPI into its build
# isolation; maturin builds the extension with the workspace's Cargo.lock in the dev profile,
# opt-level 1, reusing the dependencies `cargo test` compiled: PYTHON_WHEEL_PROFILE=release
# builds what users install), the CLI built by cargo, then pytest, which compares every method
# with the CLI.
#
# Needs python3 (>= 3.10) with venv, and PyPI. PYTHON=python3.12 picks another interpreter;
# PYTHON_SKIP_UNAVAILABLE=1 skips loudly (exit 0) when there is no interpreter or no PyPI.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

PY=${PYTHON:-python3}
# A clean Debian/Ubuntu machine may lack python3 or its venv module: install them when we can.
if ! { command -v "$PY" >/dev/null 2>&1 && "$PY" -m venv --help >/dev/null 2>&1; } \
  && command -v apt-get >/dev/null 2>&1; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null && sudo="sudo -n"
  ($sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq \
    python3 python3-venv python3-pip) >/dev/null 2>&1 || true
fi
skip() {
  if [ "${PYTHON_SKIP_UNAVAILABLE:-0}" = 1 ]; then
    echo "SKIPPED python tests: $*" >&2
    exit 0
  fi
  echo "python tests: $*" >&2
  exit 1
}
command -v "$PY" >/dev/null 2>&1 || skip "$PY not found"
"$PY" -c 'import sys; sys.exit(sys.version_info < (3, 10))' || skip "$PY is older than 3.10"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$PY" -m venv "$tmp/venv" || skip "$PY -m venv failed (install python3-venv)"
pip=("$tmp/venv/bin/pip" --disable-pip-version-check --quiet)
# mcap + mcap-protobuf-support: test_mcap_logs.py reads `robot --mcap` files with the standard
# readers, and runs docs/python.md's example, which builds a pandas DataFrame.
# yourdfpy: test_urdf.py reads `omnikin urdf` with an independent URDF parser; rosbags:
# test_ros2_messages.py re-makes the ROS 2 CDR fixture of crates/omnikin-ros2. eclipse-zenoh:
# test_ros2_node.py is a ROS 2 peer (rmw_zenoh's wire format) of `robot --sim --ros2`.
"${pip[@]}" install pytest matplotlib mcap mcap-protobuf-support pandas yourdfpy "rosbags>=0.11,<0.12" "eclipse-zenoh>=1.1,<2" \
  || skip "cannot install pytest, matplotlib, mcap, mcap-protobuf-support, pandas, yourdfpy, rosbags and eclipse-zenoh from PyPI"
# --locked: the extension builds against the committed Cargo.lock, like every other crate.
# The dev profile shares target/debug with `cargo test` (same settings, see Cargo.toml), so in CI
# only the extension's own crates compile here (~15 s instead of a release build of everything).
MATURIN_PEP517_ARGS="--locked --profile ${PYTHON_WHEEL_PROFILE:-dev}" "${pip[@]}" install ./crates/omnikin-py
# With the ROS 2 node (feature ros2): Zenoh compiles here, not in the tests stage (docs/ros2.md
# has its cost).
cargo build -p omnikin-cli --features ros2 --locked --quiet
# The Rust tests behind the `ros2` feature (the workspace's test stage builds without it): the
# node's unit tests and `ros2 --connect`'s signal handling.
cargo test -p omnikin-host --features ros2 --locked --quiet --lib ros2_node
cargo test -p omnikin-cli --features ros2 --locked --quiet --test ros2
# From another directory: the tests import the installed package, not the source tree.
# OMNIKIN_REQUIRE_ROS2: a zenoh that installed but does not import fails the node's tests
# instead of skipping them; -rs prints any skip with its reason.
cd "$tmp"
OMNIKIN_BIN="$root/target/debug/omnikin" MPLBACKEND=Agg OMNIKIN_REQUIRE_ROS2=1 \
  "$tmp/venv/bin/python" -m pytest -q -rs -p no:cacheprovider "$root/crates/omnikin-py/tests"
