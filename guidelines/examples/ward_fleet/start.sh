#!/usr/bin/env bash
# Ten UV robots on this machine, /ward/uv1 .. /ward/uv10 (guidelines/a-fleet.md): for each,
# its lifecycle nodes (the lamp's in a process of its own, so that it can fail alone) and
# `motivml run ward.fleet.json --ros2 --ros-namespace /ward/uvK` (the robot of that namespace,
# its variant with the fleet's layers) at 100 Hz, its output in /tmp/ward-uvK.log. Ctrl-C
# stops them all.
#
#   bash guidelines/examples/ward_fleet/start.sh   (MOTIVML and PYTHON: which to use)
set -euo pipefail
cd "$(dirname "$0")/../../.."
MOTIVML=${MOTIVML:-motivml}
PYTHON=${PYTHON:-python}
trap 'kill $(jobs -p) 2>/dev/null; wait' EXIT
for k in $(seq 1 10); do
  "$PYTHON" plugins/ros2/uv_nodes.py irradiation low_intensity high_intensity person_detection thermal_detection \
    --ros-args -r __ns:=/ward/uv$k > /tmp/ward-nodes-uv$k.log 2>&1 &
  "$PYTHON" plugins/ros2/uv_nodes.py lamp --ros-args -r __ns:=/ward/uv$k > /tmp/ward-lamp-uv$k.log 2>&1 &
done
sleep 5  # (the nodes on the graph before the robots ask for them: each robot waits 5 s for its own)
for k in $(seq 1 10); do
  "$MOTIVML" run guidelines/examples/ward_fleet/ward.fleet.json --ros2 --ros-namespace /ward/uv$k \
    --duration inf --rate 100 --no-live --no-control > /tmp/ward-uv$k.log 2>&1 &
done
echo "ten robots starting under /ward: motivml fleet list --prefix /ward"
wait
