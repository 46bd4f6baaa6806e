#!/usr/bin/env bash
# Renders example recordings in the Rerun viewer (rerun-sdk 0.36.3) under a virtual X server
# and screenshots them into docs/images/, as docs/visualization.md shows them.
#
# Needs (Debian): xvfb x11-apps imagemagick mesa-vulkan-drivers, and the viewer of the tests'
# virtual environment (target/rerun-venv, made by `cargo test`; or NEKOSIM_RERUN=path/to/rerun).
# The viewer plays from the start at 1x, so a screenshot taken W seconds after it opened
# shows about simulated second W (a check's step W).
#
# Usage: bash docs/screenshots.sh        (from the repository's root; takes a few minutes)
set -euo pipefail
cd "$(dirname "$0")/.."
RERUN=${NEKOSIM_RERUN:-target/rerun-venv/bin/rerun}
OUT=docs/images
WORK=$(mktemp -d)
mkdir -p "$OUT"
cargo build --quiet
BIN=target/debug/nekosim

Xvfb :99 -screen 0 1600x1000x24 -extension Composite >/dev/null 2>&1 &
XVFB=$!
trap 'kill $XVFB 2>/dev/null; pkill -f rerun_cli/rerun 2>/dev/null; rm -rf "$WORK"' EXIT
sleep 2

# shoot RRD NAME SECONDS...: one viewer, a screenshot at each wall-clock second given.
shoot() {
  local rrd=$1 name=$2
  shift 2
  pkill -f rerun_cli/rerun 2>/dev/null || true
  # The viewer keeps a user's blueprint per application; start from the recording's own.
  rm -rf "$HOME/.local/share/rerun/blueprints"
  DISPLAY=:99 CI=1 WGPU_BACKEND=vulkan "$RERUN" "$rrd" >/dev/null 2>&1 &
  local started=$SECONDS
  for at in "$@"; do
    sleep $((at - (SECONDS - started)))
    DISPLAY=:99 xwd -root -silent | convert xwd:- -resize 1200x -colors 256 "PNG8:$OUT/$name-$at.png"
    echo "$OUT/$name-$at.png"
  done
  pkill -f rerun_cli/rerun 2>/dev/null || true
  sleep 1
}

$BIN run examples/scenarios/random_movement.ron --until 45 --rrd "$WORK/random_movement.rrd" --quiet
shoot "$WORK/random_movement.rrd" random_movement 12 40
$BIN run examples/scenarios/ask_for_help.ron --until 60 --rrd "$WORK/ask_for_help.rrd" --quiet
shoot "$WORK/ask_for_help.rrd" ask_for_help 8 40
$BIN run examples/scenarios/abcast_lamport.ron --until 30 --rrd "$WORK/abcast_lamport.rrd" --quiet
shoot "$WORK/abcast_lamport.rrd" abcast_lamport 20
$BIN run examples/scenarios/obstacles.ron --until 60 --rrd "$WORK/obstacles.rrd" --quiet
shoot "$WORK/obstacles.rrd" obstacles 30
$BIN check lamport-abcast --crashes 1 --rrd "$WORK/check.rrd" >/dev/null || true
shoot "$WORK/check.rrd" check_lamport_crash 14
