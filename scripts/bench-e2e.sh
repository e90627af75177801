#!/usr/bin/env bash
# Benchmark of the end-to-end forward jump: N sensor-noise seeds of robot_client (simulated
# robot behind emulated CAN frames) against one planner_server on loopback with an empty cache,
# then N seeds of the jump onto the 0.25 m platform (simulated robot), then N seeds of the
# course (two walls 10 m apart, jumped in turn), then the vertical jump, then N seeds of the
# backflip (rolling backward at 1 m/s, against a second service on the 57 Nm-knee robot of
# the scenario's actuators_file, with config/backflip-57nm.yaml's settings; docs/backflip.md),
# then N seeds of the same flip on the real
# 42 Nm robot (backflip_42nm, a third service with config/backflip-42nm.yaml's settings).
# Prints one JSON document: per-seed outcome and the totals.
# Usage: scripts/bench-e2e.sh [build dir] [seeds] [extra robot_client options...]
# WJ_BENCH_SCENARIOS (space-separated, default all: forward platform course vertical backflip
# backflip_42nm)
# runs only those, e.g. WJ_BENCH_SCENARIOS=backflip for the flip's seeds alone.
set -euo pipefail
# DE threads sleep at the per-generation barrier (docs/planner.md, "Threads").
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
cd "$(dirname "$0")/.."
BUILD=${1:-build/release}
SEEDS=${2:-10}
shift $(( $# > 2 ? 2 : $# ))
BIN=$BUILD/bin
WORK=$(mktemp -d)
PORT=${WJ_BENCH_PORT:-50161}
source scripts/planner-server.sh
trap 'stop_planner_server; rm -rf "$WORK"' EXIT
EXTRA=("$@")  # extra robot_client options, passed to every run
SCENARIOS=${WJ_BENCH_SCENARIOS:-forward platform course vertical backflip backflip_42nm}
for s in $SCENARIOS; do
  case $s in forward | platform | course | vertical | backflip | backflip_42nm) ;;
    *) echo "bench-e2e: WJ_BENCH_SCENARIOS: '$s' is not one of forward platform course vertical backflip backflip_42nm" >&2
       exit 2 ;;
  esac
done
wanted() { [[ " $SCENARIOS " == *" $1 "* ]]; }
# The service of the shipped robot, for every scenario but the backflip.
if wanted forward || wanted platform || wanted course || wanted vertical; then
  start_planner_server "$BIN" "$PORT" "$WORK/plan_cache.sqlite" "$WORK/planner_server.yaml" \
    "$WORK/server.log"
fi
# N sensor-noise seeds of one scenario (further arguments: its backend options) into
# $WORK/<scenario>_<seed>.json and .log.
run_seeds() {
  local scenario=$1
  shift
  for seed in $(seq 1 "$SEEDS"); do
    "$BIN/robot_client" --backend sim "$@" --config config/robot_client.yaml \
      --planner "127.0.0.1:${PORT}" --scenario "$scenario" --seed "$seed" --json "${EXTRA[@]}" \
      > "$WORK/${scenario}_$seed.json" 2> "$WORK/${scenario}_$seed.log" || true
  done
}
if wanted forward; then run_seeds forward --via-can; fi
if wanted platform; then run_seeds platform; fi
if wanted course; then run_seeds course; fi
if wanted vertical; then
  "$BIN/robot_client" --backend sim --config config/robot_client.yaml \
    --planner "127.0.0.1:${PORT}" --scenario vertical --seed 1 --json "${EXTRA[@]}" \
    > "$WORK/vertical.json" 2> "$WORK/vertical.log" || true
fi
# The backflip's robot differs (actuators-57nm.yaml): a service of its own, same port.
if wanted backflip; then
  stop_planner_server
  scenario_service backflip
  start_planner_server "$BIN" "$PORT" "$WORK/plan_cache_57nm.sqlite" \
    "$WORK/planner_server_57nm.yaml" "$WORK/server_57nm.log" "${SCENARIO_SERVICE[@]}"
  run_seeds backflip
fi
# The real robot's flip (42 Nm): its planner settings file, same port.
if wanted backflip_42nm; then
  stop_planner_server
  scenario_service backflip_42nm
  start_planner_server "$BIN" "$PORT" "$WORK/plan_cache_42nm_flip.sqlite" \
    "$WORK/planner_server_42nm_flip.yaml" "$WORK/server_42nm_flip.log" "${SCENARIO_SERVICE[@]}"
  run_seeds backflip_42nm
fi
/usr/bin/python3 - "$WORK" "$SEEDS" "$SCENARIOS" <<'PY'
import json, sys, statistics
work, seeds, wanted = sys.argv[1], int(sys.argv[2]), sys.argv[3].split()
def per_seed(scenario, fields):
    """Each seed's run of a scenario: outcome plus fields(summary, simulated), or its error."""
    out = []
    for s in range(1, seeds + 1):
        try:
            d = json.load(open(f"{work}/{scenario}_{s}.json"))
        except Exception as e:
            out.append({"seed": s, "error": str(e)}); continue
        out.append({"seed": s, "success": d["success"], "verdict": d["verdict"],
                    **fields(d, d.get("simulated", {}))})
    return out

out = {}
if "forward" in wanted:
    runs = per_seed("forward", lambda d, sim: {
        "takeoff_speed_m_s": sim.get("takeoff_speed_m_s"),
        "apex_base_z_m": sim.get("apex_base_z_m"),
        "min_wall_clearance_m": sim.get("min_wall_clearance_m"),
        "planned_clearance_m": d["plan"]["predicted_clearance_m"],
        "plan_latency_ms": d["plan"]["latency_ms"], "plan_source": d["plan"]["source"]})
    ok = [r for r in runs if r.get("success")]
    cleared = [r for r in runs
               if (r.get("min_wall_clearance_m") or -1) > 0 and r.get("apex_base_z_m")]
    lat = [r["plan_latency_ms"] for r in runs if r.get("plan_latency_ms") is not None]
    clear = [r["min_wall_clearance_m"] for r in cleared]
    out["forward"] = {
        "seeds": seeds, "success": len(ok), "cleared_wall": len(cleared),
        "clearance_m": {"min": min(clear, default=None),
                        "median": statistics.median(clear) if clear else None},
        "plan_latency_ms": {"median": statistics.median(lat) if lat else None,
                            "max": max(lat) if lat else None},
        "runs": runs}
if "platform" in wanted:
    platform = per_seed("platform", lambda d, sim: {
        "landed_on_top": "landed on the platform" in d["verdict"],
        "apex_base_z_m": sim.get("apex_base_z_m"),
        "touchdown_dx_m": sim.get("touchdown_dx_m"),
        "planned_touchdown_dx_m": d["plan"]["predicted_touchdown_dx_m"],
        "final_x_m": sim.get("final_x_m"), "final_speed_m_s": sim.get("final_speed_m_s"),
        "plan_latency_ms": d["plan"]["latency_ms"], "plan_source": d["plan"]["source"],
        "transitions": [t["to"] for t in d.get("transitions", [])]})
    out["platform"] = {"seeds": seeds, "success": sum(1 for r in platform if r.get("success")),
                       "landed_on_top": sum(1 for r in platform if r.get("landed_on_top")),
                       "platform_height_m": 0.25, "runs": platform}
if "course" in wanted:
    course = per_seed("course", lambda d, sim: {
        "walls_jumped": d.get("landings"),
        "jump_wall_clearance_m": sim.get("jump_wall_clearance_m"),
        "estimator_position_rms_m": sim.get("estimator_position_rms_m"),
        "estimator_position_max_m": sim.get("estimator_position_max_m"),
        "transitions": [t["to"] for t in d.get("transitions", [])]})
    out["course"] = {"seeds": seeds, "success": sum(1 for r in course if r.get("success")),
                     "walls": 2, "runs": course}
if "vertical" in wanted:
    v = json.load(open(f"{work}/vertical.json"))
    out["vertical"] = {"success": v["success"], "verdict": v["verdict"],
                       "apex_base_z_m": v.get("simulated", {}).get("apex_base_z_m"),
                       "planned_apex_base_z_m": v["plan"]["predicted_apex_base_z_m"],
                       "paper_hardware_m": 0.5, "paper_target_m": 0.7}
for flip in ("backflip", "backflip_42nm"):
    if flip not in wanted:
        continue
    backflip = per_seed(flip, lambda d, sim: {
        "actuators_file": d.get("actuators_file"),
        "touchdown_rotation_rad": sim.get("touchdown_rotation_rad"),
        "final_rotation_rad": sim.get("final_rotation_rad"),
        "planned_touchdown_rotation_rad": d["plan"].get("predicted_touchdown_rotation_rad"),
        "apex_base_z_m": sim.get("apex_base_z_m"),
        "touchdown_dx_m": sim.get("touchdown_dx_m"),
        "knee_torque_nm": d["max_torque"]["KFE"]["max_nm"],
        "knee_limit_nm": d["max_torque"]["KFE"]["limit_nm"],
        "plan_verification": d["plan"]["verification"],
        "plan_latency_ms": d["plan"]["latency_ms"], "plan_source": d["plan"]["source"],
        "transitions": [t["to"] for t in d.get("transitions", [])]})
    out[flip] = {"seeds": seeds, "success": sum(1 for r in backflip if r.get("success")),
                 "target_rotation_rad": 6.283, "runs": backflip}
print(json.dumps(out, indent=2))
PY
