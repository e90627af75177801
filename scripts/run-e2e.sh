#!/usr/bin/env bash
# The end-to-end simulated jump (the README's main job, after the build): starts the planning
# service on loopback, then runs the robot client on the simulated robot for the forward
# scenario (roll up to 3 m/s, plan, jump over a 0.25 m wall, land, stop; every command and
# measurement through emulated MIT-mode CAN frames), the vertical scenario (crouched, as high as
# the planner reaches), the platform scenario (roll up to 3 m/s, jump onto a 0.25 m platform,
# land on its top) and the course (two 0.25 m walls 10 m apart, jumped one after the other
# without stopping, then a stop) and the backflip (rolling backward at 1 m/s, a full backward
# turn; its robot has the paper's 57 Nm knee, actuators-57nm.yaml, so a second service runs for
# it, docs/backflip.md), then the same flip on the real 42 Nm robot (backflip_42nm, a third
# service with config/backflip-42nm.yaml's planner settings). Summaries on
# stdout, telemetry and figures in out/. Usage: scripts/run-e2e.sh [build dir] [seed]
set -euo pipefail
# DE threads sleep at the per-generation barrier (docs/planner.md, "Threads").
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
cd "$(dirname "$0")/.."
BUILD=${1:-build/release}
SEED=${2:-1}
BIN=$BUILD/bin
mkdir -p out
PORT=${WJ_E2E_PORT:-50151}

# The service: the shipped configuration, listening on this port, cache under out/.
source scripts/planner-server.sh
trap stop_planner_server EXIT
start_planner_server "$BIN" "$PORT" "$(pwd)/out/plan_cache.sqlite" out/planner_server.yaml \
  out/planner_server.log

status=0
run() {
  local scenario=$1; shift
  echo "=== robot_client: $scenario ==="
  local rc=0
  "$BIN/robot_client" --backend sim "$@" --config config/robot_client.yaml \
    --planner "127.0.0.1:${PORT}" --scenario "$scenario" --seed "$SEED" \
    --csv "out/e2e_${scenario}.csv" --plot "out/e2e_${scenario}.png" \
    --snapshots "out/e2e_${scenario}_snapshots.png" --gif "out/e2e_${scenario}.gif" \
    --html "out/e2e_${scenario}.html" || rc=$?
  if [ "$rc" -eq 2 ]; then status=2; elif [ "$rc" -ne 0 ] && [ "$status" -eq 0 ]; then status=3; fi
}
run forward --via-can
run vertical
run platform
run course
# The backflip's robot (the scenario's actuators_file) differs: the service is restarted on it.
stop_planner_server
scenario_service backflip
start_planner_server "$BIN" "$PORT" "$(pwd)/out/plan_cache_57nm.sqlite" \
  out/planner_server_57nm.yaml out/planner_server_57nm.log "${SCENARIO_SERVICE[@]}"
# The client's backflip counts like every other scenario (10 of 10 noise seeds flipped, landed
# upright and stopped: docs/backflip.md, "Session 15"); its summary prints the knee's peak torque
# against its limit and the rotation at touchdown.
run backflip
# The same flip on the real robot (42 Nm): the service on actuators.yaml with the flip's planner
# settings (config/backflip-42nm.yaml, the file sim_jump's 42 Nm flip uses; docs/backflip.md,
# "Session 16").
stop_planner_server
scenario_service backflip_42nm
start_planner_server "$BIN" "$PORT" "$(pwd)/out/plan_cache_42nm_flip.sqlite" \
  out/planner_server_42nm_flip.yaml out/planner_server_42nm_flip.log "${SCENARIO_SERVICE[@]}"
run backflip_42nm
echo "telemetry and figures in out/ (e2e_*.csv, e2e_*.png; the backflip's knees over the take-off:"
echo "  out/e2e_backflip_knees.png); service logs out/planner_server*.log"
echo "pictures of the runs: out/e2e_<scenario>_snapshots.png (snapshot strip), out/e2e_<scenario>.gif"
echo "  (animation), out/e2e_<scenario>.html (3D replay: open it in a browser, works offline)"
exit "$status"
