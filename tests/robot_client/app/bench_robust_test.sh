#!/usr/bin/env bash
# One trial of the robustness campaign (scripts/bench-robust.sh) as a ctest case: the script
# draws a plant, runs robot_client on it against planner_server and prints a JSON document
# whose every failure carries a plant file that robot_client accepts (the campaigns themselves
# are benchmarks, not tests). Usage: bench_robust_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
BUILD=$1
SRC=$2
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
export WJ_BENCH_PORT=${WJ_BENCH_PORT:-$(( 54000 + RANDOM % 2000 ))}
bash "$SRC/scripts/bench-robust.sh" "$BUILD" 1 forward 7 > "$WORK/out.json" 2> "$WORK/log"
/usr/bin/python3 - "$WORK/out.json" "$WORK" <<'PY'
import json, sys, yaml
d = json.load(open(sys.argv[1]))
def check(cond, what):
    if not cond:
        print("FAILED:", what); sys.exit(1)
check(d["trials"] == 1 and d["first_seed"] == 7, "trial count and seed")
check(d["successes"] + sum(d["failure_taxonomy"].values()) == 1, "every trial classified once")
row = d["trials_detail"][0]
check(row["failure"] != "error", f"the trial did not run: {row['verdict']}")
if row["jumped"]:
    err = row["touchdown_rotation_error_rad"]
    check(err is not None and abs(err) < 1.0, f"the touchdown rotation against the plan's: {err}")
    check(d["touchdown_rotation_error_rad"]["median"] == err, "the rotation error's distribution")
for f in d["failures"]:
    plant = yaml.safe_load(f["plant_yaml"])
    check(0.5 <= plant["friction"] <= 1.0, "friction drawn from its range")
    check(0.0 <= plant["payload"]["mass_kg"] <= 2.0, "payload drawn from its range")
print("OK", row["success"], row["failure"], row["clearance_m"])
PY
