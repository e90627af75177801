#!/usr/bin/env bash
# The randomized robustness campaign (issue 18): N seeded trials of a robot client scenario,
# each on a simulated robot that differs from the model the planner, the NMPC and the
# estimator assume: a plant drawn from the ranges below (docs/robot-client.md, "Robustness")
# and passed as `robot_client --plant`. One planner_server on loopback serves every trial.
# Prints one JSON document: the success rate, a failure taxonomy, the distributions of the
# simulated wall clearance, the roll-on speed and the rotation at touchdown against the plan's
# (its last landing's), and every failure's seed and plant, so that it can be replayed:
#   robot_client --backend sim --config config/robot_client.yaml --planner HOST:PORT \
#     --scenario forward --seed SEED --plant failure.yaml
# Usage: scripts/bench-robust.sh [build dir] [trials] [scenario] [first seed] [robot_client options...]
# The flips (backflip, backflip_42nm) get their own service, as scripts/run-e2e.sh starts it.
# Trial i uses seed = first seed + i - 1 for both the plant draw and the sensor noise.
# WJ_WALL_ERROR=seen (default) | unseen: the drawn wall position error is seen by the range
# sensor (the configuration is wrong, the sensor measures the real wall) or not (the sensor has
# the opposite bias, plant key range_bias_m = -wall_position_error_m, and reads the configured
# place).
set -euo pipefail
if [ "${1:-}" = "-h" ] || [ "${1:-}" = "--help" ]; then
  sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'
  exit 0
fi
# DE threads sleep at the per-generation barrier (docs/planner.md, "Threads").
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
cd "$(dirname "$0")/.."
BUILD=${1:-build/release}
TRIALS=${2:-30}
SCENARIO=${3:-forward}
FIRST=${4:-1}
shift $(( $# > 4 ? 4 : $# ))
BIN=$BUILD/bin
for exe in robot_client planner_server planner_cli; do
  if [ ! -x "$BIN/$exe" ]; then
    echo "bench-robust: $BIN/$exe not found (first argument: the build directory; --help)" >&2
    exit 2
  fi
done
WORK=$(mktemp -d)
PORT=${WJ_BENCH_PORT:-50161}
WALL_ERROR=${WJ_WALL_ERROR:-seen}
case "$WALL_ERROR" in seen|unseen) ;; *) echo "WJ_WALL_ERROR must be seen or unseen, got '$WALL_ERROR'" >&2; exit 2;; esac
source scripts/planner-server.sh
trap 'stop_planner_server; rm -rf "$WORK"' EXIT
# The flips' robots and planner settings differ (scenario_service).
scenario_service "$SCENARIO"
start_planner_server "$BIN" "$PORT" "$WORK/plan_cache.sqlite" "$WORK/planner_server.yaml" \
  "$WORK/server.log" "${SCENARIO_SERVICE[@]}"

# The plant of trial `seed`: the campaign's ranges, drawn by a generator seeded with it.
draw_plant() {
  /usr/bin/python3 - "$1" "$2" "$WALL_ERROR" <<'PY'
import random, re, sys
seed, out, wall_error = int(sys.argv[1]), sys.argv[2], sys.argv[3]
# The base's collision box (the URDF's first box) bounds the payload's position.
urdf = open("models/wheeljump.urdf").read()
box = [float(v) for v in re.search(r'<box size="([^"]+)"', urdf).group(1).split()]
rng = random.Random(seed)
def direction():
    while True:
        v = [rng.uniform(-1, 1) for _ in range(3)]
        n = sum(x * x for x in v) ** 0.5
        if 0.1 < n <= 1:
            return [x / n for x in v]
mass = rng.uniform(0.0, 2.0)
offset = [rng.uniform(-h / 2, h / 2) for h in box]
gyro = [rng.uniform(0.0, 0.02) * x for x in direction()]
plant = {
    "payload": {"mass_kg": mass, "offset_m": offset},
    "link_mass_scale": rng.uniform(0.95, 1.05),
    "friction": rng.uniform(0.5, 1.0),
    "torque_scale": rng.uniform(0.9, 1.0),
    "corner_speed_scale": rng.uniform(0.9, 1.1),
    "motor_latency_s": rng.uniform(0.0, 0.002),
    "imu_gyro_bias_rad_s": gyro,
    "wall_position_error_m": rng.uniform(-0.1, 0.1),
}
if wall_error == "unseen":
    plant["range_bias_m"] = -plant["wall_position_error_m"]
def fmt(v):
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {fmt(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(fmt(x) for x in v) + "]"
    return repr(float(v))
with open(out, "w") as f:
    for k, v in plant.items():
        f.write(f"{k}: {fmt(v)}\n")
PY
}

for i in $(seq 1 "$TRIALS"); do
  seed=$(( FIRST + i - 1 ))
  draw_plant "$seed" "$WORK/plant_$seed.yaml"
  rc=0
  "$BIN/robot_client" --backend sim --config config/robot_client.yaml \
    --planner "127.0.0.1:${PORT}" --scenario "$SCENARIO" --seed "$seed" --fast --json \
    --plant "$WORK/plant_$seed.yaml" "$@" \
    > "$WORK/trial_$seed.json" 2> "$WORK/trial_$seed.log" || rc=$?
  echo "$rc" > "$WORK/trial_$seed.rc"
  echo "trial $i/$TRIALS (seed $seed): exit $rc" >&2
done

/usr/bin/python3 - "$WORK" "$TRIALS" "$FIRST" "$SCENARIO" "$WALL_ERROR" <<'PY'
import json, statistics, sys, yaml
work, trials, first, scenario = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
wall_error = sys.argv[5]
# A course lists several walls (wall.x_m), jumped in turn.
wall_x = yaml.safe_load(open("config/robot_client.yaml"))["scenarios"][scenario]["wall"]["x_m"]
walls = len(wall_x) if isinstance(wall_x, list) else 1

def classify(d, rc):
    """One failure class per trial (None: success), first match wins."""
    if d is None or rc == 2:
        return "error"
    if d["success"]:
        return None
    damping = [t for t in d["transitions"] if t["to"] == "DAMPING"]
    why = damping[-1]["reason"] if damping else ""
    sim = d.get("simulated", {})
    clearance = sim.get("min_wall_clearance_m")
    if why == "state estimator diverged":
        return "estimator_diverged"
    if not d["jumped"]:
        return "aborted: " + (d["abort_reason"] or "run ended")
    if d.get("landings", 1) < walls and d["abort_reason"] and (clearance is None or clearance > 0):
        return f"aborted before wall {d.get('landings', 1) + 1}: " + d["abort_reason"]
    if clearance is not None and clearance <= 0.0:
        return "hit_wall"
    if damping or sim.get("body_touched_ground") or "NOT upright" in d["verdict"]:
        return "fell_on_landing"
    if "DID NOT TURN" in d["verdict"]:
        return "did_not_turn"
    if "DID NOT CLEAR" in d["verdict"]:
        return "did_not_clear"
    if "DID NOT ROLL ON" in d["verdict"]:
        return "did_not_roll_on"
    if "not stopped" in d["verdict"]:
        return "not_stopped"
    return "other"

def stats(values):
    v = sorted(x for x in values if x is not None)
    if not v:
        return None
    q = lambda p: v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))]
    return {"n": len(v), "min": v[0], "p10": q(0.1), "median": statistics.median(v),
            "p90": q(0.9), "max": v[-1]}

rows, failures, taxonomy = [], [], {}
for i in range(trials):
    seed = first + i
    plant_text = open(f"{work}/plant_{seed}.yaml").read()
    rc = int(open(f"{work}/trial_{seed}.rc").read())
    try:
        d = json.load(open(f"{work}/trial_{seed}.json"))
    except (OSError, ValueError):
        d = None
    why = classify(d, rc)
    sim = (d or {}).get("simulated", {})
    row = {"seed": seed, "exit": rc, "success": why is None, "failure": why,
           "jumped": bool((d or {}).get("jumped")),
           "clearance_m": sim.get("min_wall_clearance_m"),
           "roll_on_speed_m_s": sim.get("roll_on_speed_m_s"),
           "takeoff_speed_m_s": sim.get("takeoff_speed_m_s"),
           "apex_base_z_m": sim.get("apex_base_z_m"),
           # Simbody's rotation at the (last) touchdown less the plan's prediction
           "touchdown_rotation_error_rad": (
               sim["touchdown_rotation_rad"] - d["plan"]["predicted_touchdown_rotation_rad"]
               if sim.get("touchdown_rotation_rad") is not None and d["plan"].get(
                   "predicted_touchdown_rotation_rad") is not None else None),
           "estimator_position_rms_m": sim.get("estimator_position_rms_m"),
           "estimator_position_max_m": sim.get("estimator_position_max_m"),
           # the scenarios run along +x: how far a landing turned the robot, and where it ended
           "max_heading_after_landing_rad": sim.get("max_heading_after_landing_rad"),
           "final_heading_rad": sim.get("final_heading_rad"),
           "final_y_m": sim.get("final_y_m"),
           "jump_clearances_m": sim.get("jump_wall_clearance_m"),
           "landings": (d or {}).get("landings"),
           # requests repeated after an answer without a plan (planner.retries)
           "plan_retries": sum(1 for t in (d or {}).get("transitions", [])
                               if t["reason"] == "no usable plan, requested again"),
           "plan": (d or {}).get("plan", {}).get("source"),
           "plan_summary": (d or {}).get("plan", {}).get("summary"),
           "verdict": (d or {}).get("verdict", open(f"{work}/trial_{seed}.log").read()[-300:])}
    rows.append(row)
    if why is not None:
        taxonomy[why] = taxonomy.get(why, 0) + 1
        failures.append({"seed": seed, "failure": why, "verdict": row["verdict"],
                         "plan_summary": row["plan_summary"],
                         "plant": yaml.safe_load(plant_text), "plant_yaml": plant_text})
ok = sum(r["success"] for r in rows)
jumped = [r for r in rows if r["jumped"] and r["clearance_m"] is not None]
print(json.dumps({
    "scenario": scenario, "trials": trials, "first_seed": first,
    "ranges": {"payload_mass_kg": [0, 2], "payload_offset": "uniform in the base box",
               "link_mass_scale": [0.95, 1.05], "friction": [0.5, 1.0],
               "torque_scale": [0.9, 1.0], "corner_speed_scale": [0.9, 1.1],
               "motor_latency_s": [0, 0.002], "imu_gyro_bias_rad_s": "|b| <= 0.02",
               "wall_position_error_m": [-0.1, 0.1],
               "wall_error_seen_by_range_sensor": wall_error == "seen"},
    "successes": ok, "success_rate": ok / trials if trials else 0.0,
    "jumped": len(jumped),
    "trials_with_plan_retries": sum(1 for r in rows if r["plan_retries"] > 0),
    "failure_taxonomy": taxonomy,
    "hit_the_wall": sum(1 for r in jumped if r["clearance_m"] <= 0.0),
    "clearance_m": stats(r["clearance_m"] for r in jumped),  # trials that jumped
    "roll_on_speed_m_s": stats(r["roll_on_speed_m_s"] for r in rows),
    "touchdown_rotation_error_rad": stats(r["touchdown_rotation_error_rad"] for r in rows
                                          if r["jumped"]),
    "estimator_position_rms_m": stats(r["estimator_position_rms_m"] for r in rows),
    "estimator_position_max_m": stats(r["estimator_position_max_m"] for r in rows),
    "max_heading_after_landing_rad": stats(r["max_heading_after_landing_rad"] for r in rows),
    "final_abs_heading_rad": stats(abs(r["final_heading_rad"]) for r in rows
                                   if r["final_heading_rad"] is not None),
    "final_abs_y_m": stats(abs(r["final_y_m"]) for r in rows if r["final_y_m"] is not None),
    "failures": failures, "trials_detail": rows}, indent=1))
PY
