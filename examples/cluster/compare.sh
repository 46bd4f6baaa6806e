#!/usr/bin/env bash
# Real network against simulation (docs/performance.md): 3 nodes of Fifo + Lamport abcast on
# localhost, each broadcasting 200 messages at 200 per second, then the same stack and load in
# the simulator over RandomDelay with the mean link delay the real run measured.
#
# Usage: bash examples/cluster/compare.sh [NEKOSIM]   (default: target/release/nekosim)
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN=${1:-target/release/nekosim}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
head -c 32 /dev/urandom > "$WORK/cluster.key"
sed 's/count: 50, period: 0.02/count: 200, period: 0.005/' examples/cluster/lamport3.ron > "$WORK/bench.ron"
echo "== real network (3 processes, localhost)"
"$BIN" cluster "$WORK/bench.ron" --out "$WORK/out" | tail -2
delay=$(sed -n 's/^link delay .*: mean \([0-9.]*\) s.*/\1/p' "$WORK/out/summary.txt")
echo "== simulation, RandomDelay(lambda: $delay)"
"$BIN" run examples/scenarios/abcast_lamport.ron \
  --set 'robots[0].count=3' \
  --set 'robots[0].born=Points([(0.0, 0.0), (30.0, 0.0), (0.0, 30.0)])' \
  --set 'robots[0].algorithm=BroadcastLoad(layer: "abcast", count: 200, mean_interval: 0.005)' \
  --set "network=RandomDelay(lambda: $delay)" --set until=10.0 | tail -1
