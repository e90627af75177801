"""sim.fidelity_seed1: scripts/bench-fidelity.sh on planner seed 1 of the forward and the
vertical preset. Checks that the JSON has every field the fidelity table of docs/sim.md is
made of, that both runs pass verification, and that seed 1 meets the targets of issue #4 that
the simulation answers for: simulated CoM apex within 3 cm of the plan's prediction, no joint
outside its envelope, upright landing, and the flight's dx within 5 cm where the plan puts its
touchdown (dx_at_planned_touchdown_height_m). The dx at the first wheel contact is reported,
not checked: the planner's touchdown is the CoM reaching the level standing height of the
landing posture, which with a nose-up landing pitch lies 4-6 cm below the first wheel contact
(planned_touchdown_wheel_gap_m < 0), so the forward preset misses it by 3-10 cm whatever the
simulation does (docs/sim.md, "Fidelity").

usage: check_fidelity.py BENCH_SCRIPT BUILD_DIR
"""
import json
import subprocess
import sys

script, build = sys.argv[1], sys.argv[2]
out = subprocess.run(["bash", script, build, "1"], check=True, capture_output=True, text=True)
doc = json.loads(out.stdout)

RUN_FIELDS = ["seed", "plan_feasible", "planned", "simulated", "error", "max_envelope_ratio",
              "max_speed_ratio", "landed_upright", "passed", "failures", "targets_met",
              "planned_touchdown_wheel_gap_m"]
VALUES = ["com_apex_z_m", "base_apex_z_m", "touchdown_dx_m", "touchdown_pitch_rad"]
SUMMARY = ["runs", "errors", "passed", "abs_apex_error_m", "abs_dx_error_m", "meeting"]
problems = []
for task in ("forward", "vertical"):
    t = doc["tasks"][task]
    problems += [f"{task}: summary lacks {k}" for k in SUMMARY if k not in t["summary"]]
    for k in ("median", "max"):
        for m in ("abs_apex_error_m", "abs_dx_error_m"):
            if not isinstance(t["summary"][m][k], float):
                problems.append(f"{task}: summary {m}.{k} is not a number")
    (run,) = t["runs"]
    if "run_error" in run:
        problems.append(f"{task}: sim_jump failed: {run['run_error']}")
        continue
    problems += [f"{task}: run lacks {k}" for k in RUN_FIELDS if k not in run]
    for part in ("planned", "simulated", "error"):
        problems += [f"{task}: {part} lacks {k}" for k in VALUES if k not in run[part]]
    for target in ("apex", "envelope", "upright"):
        if not run["targets_met"][target]:
            problems.append(f"{task} seed 1 misses the {target} target: error {run['error']}, "
                            f"envelope {run['max_envelope_ratio']:.3f}, failures {run['failures']}")
    flight_dx = run["error"].get("dx_at_planned_touchdown_height_m")
    if flight_dx is None or abs(flight_dx) > doc["targets"]["dx_m"]:
        problems.append(f"{task} seed 1: flight dx error at the planned touchdown height "
                        f"{flight_dx} m (allowed {doc['targets']['dx_m']} m)")
    if not run["passed"]:
        problems.append(f"{task} seed 1 fails verification: {run['reasons']}")
if problems:
    print("\n".join(problems), file=sys.stderr)
    sys.exit(1)
print("fidelity: forward and vertical seed 1 pass and meet the simulation's targets")
