#!/usr/bin/env bash
# `make demo`: the twin node, a command script driving a speed/temperature/preload profile and
# a console view (torque, fidelity, real-time factor, health once a second), started together
# by `ballscrew-twin launch config/launch/demo.yaml` for DEMO_DURATION seconds (default 10),
# on this machine only. Ends with a summary and a plot (DEMO_PLOT, default
# out/demo/twin_demo.png); exit 0 when every process ended cleanly and torque arrived.
# Expects .venv (make setup) and, from the Makefile, ROS_AUTOMATIC_DISCOVERY_RANGE /
# ROS_DOMAIN_ID; sets loopback defaults itself otherwise.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="$ROOT/.venv/bin"
export DEMO_DURATION="${DEMO_DURATION:-10}"
export DEMO_PLOT="${DEMO_PLOT:-$ROOT/out/demo/twin_demo.png}"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(($$ % 100 + 1))}"
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE || true
# Line-buffered ROS log output, so node warnings interleave with the other lines.
export RCUTILS_LOGGING_BUFFERED_STREAM="${RCUTILS_LOGGING_BUFFERED_STREAM:-1}"

[[ -x "$BIN/ballscrew-twin" ]] || { echo "run_demo: $BIN/ballscrew-twin missing: run 'make setup'" >&2; exit 1; }

echo "demo: twin node + command script + console view for ${DEMO_DURATION} s" \
     "(ROS_DOMAIN_ID=$ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE)"
rc=0
"$BIN/ballscrew-twin" launch "$ROOT/config/launch/demo.yaml" || rc=$?
if [[ $rc -ne 0 ]]; then
    echo "demo: FAILED (launch exit $rc)" >&2
    exit "$rc"
fi
echo "demo: done, plot in $DEMO_PLOT"
