#!/usr/bin/env bash
# The main job: installs the dependencies, builds the release preset, then plans the paper's
# jumps with the DE + Ipopt planner and verifies each plan in the Simbody simulation (sim_jump),
# printing prediction and simulation side by side and writing telemetry and figures to out/.
# Exit status of sim_jump: 0 verified, 3 infeasible target or failed verification (reported),
# 2 error; only an error stops this script.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
cmake --preset release
cmake --build --preset release
mkdir -p out
status=0
for task in forward_hw vertical forward; do
  echo "=== $task ==="
  rc=0
  build/release/bin/sim_jump --task "$task" --csv "out/$task.csv" --plot "out/$task.png" || rc=$?
  if [ "$rc" -eq 2 ]; then status=2; fi
done
echo "telemetry and figures in out/"
exit "$status"
