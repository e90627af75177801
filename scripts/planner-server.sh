# Sourced by the run and bench scripts and the e2e tests: starts the planning service on loopback.
# shellcheck shell=bash
#
#   start_planner_server BIN PORT CACHE_FILE CONFIG_OUT LOG [ACTUATORS_FILE [SETTINGS_FILE]]
#
# writes the shipped config/planner_server.yaml listening on 127.0.0.1:PORT with its cache at
# CACHE_FILE and its planner settings file found in the repository's config/ (and, if given,
# the robot of ACTUATORS_FILE in the models folder, e.g. actuators-57nm.yaml for the backflip,
# with the planner's default settings, or with SETTINGS_FILE, a planner settings file named
# from the repository's root, e.g. config/backflip-42nm.yaml) to CONFIG_OUT, starts
# BIN/planner_server in the
# background (its pid in SERVER, stopped by stop_planner_server) and waits up to 10 s until it
# answers.

# The shipped configuration is found beside this file, so callers may run from any folder.
WJ_PLANNER_SERVER_SH_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

start_planner_server() {
  local bin=$1 port=$2 cache=$3 config=$4 log=$5 actuators=${6:-} settings=${7:-}
  local robot=()
  # Another robot (the backflip's 57 Nm knee) plans with the planner's defaults: the shipped
  # settings file (a wall's margin, the flight tuck) was measured for the wall jumps of
  # actuators.yaml, and its tuck leaves the standing flip without a plan (docs/robust.md).
  if [ -n "$actuators" ]; then
    local with=""
    if [ -n "$settings" ]; then with="${WJ_PLANNER_SERVER_SH_DIR}/../${settings}"; fi
    robot=(-e "s|^actuators_file: .*|actuators_file: ${actuators}|"
           -e "s|^  settings_file: .*|  settings_file: \"${with}\"|")
  fi
  # The shipped settings_file is beside the shipped config (a relative path is resolved against
  # the config's folder); the config is written elsewhere, so the path is made absolute here.
  sed -e "s|^listen: .*|listen: \"127.0.0.1:${port}\"|" \
      -e "s|^  path: .*|  path: \"${cache}\"|" "${robot[@]}" \
      -e "s|^  settings_file: \"planner_settings.yaml\"|  settings_file: \"${WJ_PLANNER_SERVER_SH_DIR}/../config/planner_settings.yaml\"|" \
      -e "s|^  jump_executor_file: \"jump_executor.yaml\"|  jump_executor_file: \"${WJ_PLANNER_SERVER_SH_DIR}/../config/jump_executor.yaml\"|" \
      "$WJ_PLANNER_SERVER_SH_DIR/../config/planner_server.yaml" > "$config"
  "$bin/planner_server" --config "$config" > "$log" 2>&1 &
  SERVER=$!
  for _ in $(seq 1 100); do
    "$bin/planner_cli" --target "127.0.0.1:${port}" --deadline-ms 500 stats > /dev/null 2>&1 && break
    sleep 0.1
  done
}

# The service a robot client scenario needs, as start_planner_server's last two arguments, in the
# array SCENARIO_SERVICE: the flips' robots and planner settings differ (the 57 Nm knee of the
# scenario's actuators_file with config/backflip-57nm.yaml; the real 42 Nm robot with
# config/backflip-42nm.yaml, docs/backflip.md); every other scenario has the shipped service (empty).
scenario_service() {
  # shellcheck disable=SC2034  # SCENARIO_SERVICE is this function's result, read by the caller
  case "$1" in
    backflip) SCENARIO_SERVICE=(actuators-57nm.yaml config/backflip-57nm.yaml) ;;
    backflip_42nm) SCENARIO_SERVICE=(actuators.yaml config/backflip-42nm.yaml) ;;
    *) SCENARIO_SERVICE=() ;;
  esac
}

stop_planner_server() {
  if [ -n "${SERVER:-}" ]; then kill "$SERVER" 2>/dev/null || true; wait "$SERVER" 2>/dev/null || true; fi
}
