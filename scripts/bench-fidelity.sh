#!/usr/bin/env bash
# Fidelity benchmark of the planner against the Simbody simulation (docs/sim.md, issue #4):
# plans the forward and the vertical preset with each planner seed, verifies every plan in
# Simbody (sim_jump --json) and prints ONE JSON document: per task and seed the planned and
# simulated CoM apex, base apex, touchdown dx and touchdown pitch, the envelope ratio, the
# landing and the verdict; per task the median and max |apex error| and |dx error| and how
# many seeds meet each target:
#   apex    |simulated - planned CoM apex height| <= 0.03 m
#   dx      |simulated - planned touchdown CoM x| <= 0.05 m
#   envelope  take-off demand / envelope torque limit <= 1, no speed or joint-range failure
#   upright   landed upright (verifier's landed_upright)
# Diagnostics per seed: error.dx_at_planned_touchdown_height_m (the simulated flight carried
# ballistically to the CoM height of the plan's touchdown) and planned_touchdown_wheel_gap_m
# (lowest wheel's distance to the terrain in the plan's touchdown state; < 0: the plan's
# touchdown comes after the first wheel contact, which is what the simulation measures).
# Usage: scripts/bench-fidelity.sh [build dir] [seeds] [tasks]
#   seeds: a count N (seeds 1..N, default 10) or a comma-separated list (e.g. 3,7)
#   tasks: comma-separated sim_jump presets (default forward,vertical)
# Runs one sim_jump at a time (each plans with 2 threads). Exit code 0 once the JSON is
# printed, whatever the verdicts; 2 if a binary is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build/release}
SEEDS=${2:-10}
TASKS=${3:-forward,vertical}
SIM_JUMP=$BUILD/bin/sim_jump
[ -x "$SIM_JUMP" ] || { echo "bench-fidelity: $SIM_JUMP not found (build target sim_jump)" >&2; exit 2; }
if [[ $SEEDS == *,* ]]; then SEED_LIST=${SEEDS//,/ }; else SEED_LIST=$(seq 1 "$SEEDS"); fi
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
for task in ${TASKS//,/ }; do
  for seed in $SEED_LIST; do
    # Exit code 3 = verification failed, a normal answer recorded in the JSON.
    rc=0
    "$SIM_JUMP" --task "$task" --seed "$seed" --json > "$WORK/${task}_${seed}.json" \
      2> "$WORK/${task}_${seed}.log" || rc=$?
    echo "$rc" > "$WORK/${task}_${seed}.rc"
  done
done
COMMIT=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
/usr/bin/python3 - "$WORK" "$TASKS" "$COMMIT" "$BUILD" $SEED_LIST <<'PY'
import json, statistics, sys

work, tasks, commit, build = sys.argv[1], sys.argv[2].split(","), sys.argv[3], sys.argv[4]
seeds = [int(s) for s in sys.argv[5:]]
TARGETS = {"apex_m": 0.03, "dx_m": 0.05, "envelope_ratio": 1.0}
ENVELOPE_FAILURES = {"torque_limit", "speed_limit", "joint_limit"}
G = 9.81  # the verifier's default gravity [m/s^2]


def run(task, seed):
    rc = int(open(f"{work}/{task}_{seed}.rc").read())
    try:
        d = json.load(open(f"{work}/{task}_{seed}.json"))
    except Exception:
        err = open(f"{work}/{task}_{seed}.log").read().strip()
        return {"seed": seed, "exit_code": rc, "run_error": err or "no JSON output"}
    p, s, v = d["predicted"], d["simulated"], d["verification"]
    planned = {"com_apex_z_m": p["apex"]["com_z"], "base_apex_z_m": p["apex"]["base_z"],
               "touchdown_dx_m": p["touchdown"]["com_x"],
               "touchdown_pitch_rad": p["touchdown"]["pitch"],
               "touchdown_com_z_m": p["touchdown"]["com_z"]}
    simulated = {"com_apex_z_m": s["apex"]["com_z"], "base_apex_z_m": v["max_base_z_m"],
                 "touchdown_dx_m": s["touchdown"]["com_x"],
                 "touchdown_pitch_rad": s["touchdown"]["pitch"],
                 "touchdown_com_z_m": s["touchdown"]["com_z"]}
    error = {k: simulated[k] - planned[k] for k in planned}
    # Diagnostic, not a target: where the simulated flight would cross the CoM height at
    # which the plan puts its touchdown (ballistic from the simulated first wheel contact).
    # It separates the flight's own error from a different touchdown height.
    td = s["touchdown"]
    dz = p["touchdown"]["com_z"] - td["com_z"]
    disc = td["com_vz"] ** 2 - 2.0 * G * dz
    if disc >= 0.0:
        t_cross = (td["com_vz"] + disc ** 0.5) / G
        error["dx_at_planned_touchdown_height_m"] = \
            td["com_x"] + td["com_vx"] * t_cross - p["touchdown"]["com_x"]
    failures = v.get("failures", [])
    ratio = v["max_envelope_ratio"]
    met = {"apex": abs(error["com_apex_z_m"]) <= TARGETS["apex_m"],
           "dx": abs(error["touchdown_dx_m"]) <= TARGETS["dx_m"],
           "envelope": ratio <= TARGETS["envelope_ratio"]
                       and not ENVELOPE_FAILURES.intersection(failures),
           "upright": bool(v["landed_upright"])}
    met["all"] = all(met.values())
    return {"seed": seed, "exit_code": rc, "plan_feasible": d["plan"]["feasible"],
            "planned": planned, "simulated": simulated, "error": error,
            # Lowest wheel's distance to the terrain in the plan's own touchdown state
            # (negative: the plan's touchdown comes after the first wheel contact).
            "planned_touchdown_wheel_gap_m": p["touchdown"].get("lowest_wheel_gap_m"),
            "max_envelope_ratio": ratio,
            "max_speed_ratio": v.get("max_speed_ratio"),
            "landed_upright": v["landed_upright"], "passed": v["passed"],
            "failures": failures, "reasons": v["reasons"], "targets_met": met}


def stats(values):
    values = [abs(x) for x in values]
    if not values:
        return {"median": None, "max": None}
    return {"median": statistics.median(values), "max": max(values)}


out = {"commit": commit, "build": build, "seeds": seeds, "targets": TARGETS, "tasks": {}}
for task in tasks:
    runs = [run(task, seed) for seed in seeds]
    ok = [r for r in runs if "run_error" not in r]
    out["tasks"][task] = {
        "summary": {
            "runs": len(runs), "errors": len(runs) - len(ok),
            "plan_feasible": sum(bool(r["plan_feasible"]) for r in ok),
            "passed": sum(bool(r["passed"]) for r in ok),
            "abs_apex_error_m": stats([r["error"]["com_apex_z_m"] for r in ok]),
            "abs_base_apex_error_m": stats([r["error"]["base_apex_z_m"] for r in ok]),
            "abs_dx_error_m": stats([r["error"]["touchdown_dx_m"] for r in ok]),
            "abs_touchdown_com_z_error_m": stats([r["error"]["touchdown_com_z_m"] for r in ok]),
            "abs_dx_at_planned_touchdown_height_error_m": stats(
                [r["error"]["dx_at_planned_touchdown_height_m"] for r in ok
                 if "dx_at_planned_touchdown_height_m" in r["error"]]),
            "abs_touchdown_pitch_error_rad": stats(
                [r["error"]["touchdown_pitch_rad"] for r in ok]),
            "planned_touchdown_wheel_gap_m": stats(
                [r["planned_touchdown_wheel_gap_m"] for r in ok
                 if r["planned_touchdown_wheel_gap_m"] is not None]),
            "max_envelope_ratio": max((r["max_envelope_ratio"] for r in ok), default=None),
            "meeting": {k: sum(r["targets_met"][k] for r in ok)
                        for k in ("apex", "dx", "envelope", "upright", "all")},
        },
        "runs": runs,
    }
print(json.dumps(out, indent=2))
PY
