#!/usr/bin/env bash
# `make demo`: run the twin node and the demo command publisher side by side for
# DEMO_DURATION seconds (default 10) on this machine only, then stop the node. Exit 0 when the
# commander received drag torque. Expects .venv (make setup) and, from the Makefile,
# ROS_AUTOMATIC_DISCOVERY_RANGE / ROS_DOMAIN_ID; sets loopback defaults itself otherwise.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BIN="$ROOT/.venv/bin"
DURATION="${DEMO_DURATION:-10}"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(($$ % 100 + 1))}"
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE || true
# Line-buffered ROS log output, so node warnings interleave with the commander's lines.
export RCUTILS_LOGGING_BUFFERED_STREAM="${RCUTILS_LOGGING_BUFFERED_STREAM:-1}"

[[ -x "$BIN/twin_node" ]] || { echo "run_demo: $BIN/twin_node missing: run 'make setup'" >&2; exit 1; }

echo "demo: twin node + command publisher for ${DURATION} s" \
     "(ROS_DOMAIN_ID=$ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE=$ROS_AUTOMATIC_DISCOVERY_RANGE)"

"$BIN/twin_node" --ros-args --params-file "$ROOT/config/twin_node.yaml" &
NODE_PID=$!

stop_node() {
    if kill -0 "$NODE_PID" 2>/dev/null; then
        kill -INT "$NODE_PID" 2>/dev/null || true
        # Give rclpy 5 s to shut down cleanly, then insist.
        for _ in $(seq 50); do
            kill -0 "$NODE_PID" 2>/dev/null || break
            sleep 0.1
        done
        kill -KILL "$NODE_PID" 2>/dev/null || true
    fi
}
trap stop_node EXIT

rc=0
"$BIN/twin_demo_commander" --duration "$DURATION" || rc=$?
stop_node
node_rc=0
wait "$NODE_PID" || node_rc=$?
trap - EXIT
if [[ $rc -ne 0 ]]; then
    echo "demo: FAILED (commander exit $rc)" >&2
    exit "$rc"
fi
if [[ $node_rc -ne 0 ]]; then
    echo "demo: FAILED (twin node exit $node_rc)" >&2
    exit "$node_rc"
fi
echo "demo: done"
