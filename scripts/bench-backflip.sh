#!/usr/bin/env bash
# The knee-torque sweep of the backflip with a "verified in Simbody" column (issue 17 item 3,
# docs/backflip.md): for each knee peak torque (42, 47, 52, 57 Nm; every other actuator as in
# models/actuators.yaml) and each start (standing, rolling backward at 1 m/s), N planner seeds
# of `sim_jump --task backflip`: is a flip planned (feasible, target met), does Simbody meet
# the issue's criterion with it (rotation within 0.3 rad of 2 pi at touchdown, landed upright,
# touchdown between the start and 0.65 m behind it, no body or leg on the ground), does it pass
# the verifier's full check (which also bounds the apex and touchdown errors against the plan's
# prediction and the demanded torques), and the rotation at touchdown, lift-off pitch and
# velocity, apex and knee torque of each.
# Prints one JSON document. Usage: scripts/bench-backflip.sh [build dir] [seeds] [torques...]
set -euo pipefail
# DE threads sleep at the per-generation barrier (docs/planner.md, "Threads").
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
cd "$(dirname "$0")/.."
BUILD=${1:-build/release}
SEEDS=${2:-10}
shift $(( $# > 2 ? 2 : $# ))
TORQUES=("$@")
if [ "${#TORQUES[@]}" -eq 0 ]; then TORQUES=(42 47 52 57); fi
BIN=$BUILD/bin
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
for nm in "${TORQUES[@]}"; do
  # The 57 Nm file with the knee's peak torque replaced: one file per robot of the sweep.
  sed -e "s|^  KFE: .*|  KFE: ${nm}.0|" models/actuators-57nm.yaml > "$WORK/actuators-${nm}nm.yaml"
  grep -q "KFE: ${nm}.0" "$WORK/actuators-${nm}nm.yaml" || { echo "no KFE override"; exit 2; }
  for start in standing rolling_back; do
    v0=0.0
    if [ "$start" = rolling_back ]; then v0=-1.0; fi
    for seed in $(seq 1 "$SEEDS"); do
      "$BIN/sim_jump" --task backflip --v0 "$v0" --actuators "$WORK/actuators-${nm}nm.yaml" \
        --seed "$seed" --threads 2 --json > "$WORK/${nm}_${start}_${seed}.json" \
        2> "$WORK/${nm}_${start}_${seed}.log" || true
    done
  done
done
/usr/bin/python3 - "$WORK" "$SEEDS" "${TORQUES[@]}" <<'PY'
import json, math, statistics, sys
work, seeds, torques = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
rows = []
for nm in torques:
    for start in ("standing", "rolling_back"):
        runs = []
        for s in range(1, seeds + 1):
            path = f"{work}/{nm}_{start}_{s}.json"
            try:
                d = json.load(open(path))
            except Exception:
                # No valid trajectory at all (sim_jump exits 2 before verifying).
                runs.append({"seed": s, "planned": False, "verified": False,
                             "error": open(path.replace(".json", ".log")).read().strip()[-200:]})
                continue
            p, sim, v = d["plan"], d["simulated"], d["verification"]
            planned = bool(p["feasible"]) and "target is met" in p["summary"]
            td = sim["touchdown"]
            flipped = (planned and abs(td["pitch"] - 2 * math.pi) <= 0.3 and v["landed_upright"]
                       and -0.65 <= td["com_x"] <= 0.0 and "base_contact" not in v["failures"]
                       and "leg_contact" not in v["failures"])
            runs.append({
                "seed": s, "planned": planned, "flipped": flipped,
                "verified": planned and bool(v["passed"]),
                "planned_touchdown_pitch_rad": d["predicted"]["touchdown"]["pitch"],
                "touchdown_pitch_rad": sim["touchdown"]["pitch"],
                "liftoff_pitch_rad": sim["takeoff"]["pitch"],
                "planned_liftoff_pitch_rad": d["predicted"]["takeoff"]["pitch"],
                "liftoff_vx_m_s": sim["takeoff"]["com_vx"],
                "planned_liftoff_vx_m_s": d["predicted"]["takeoff"]["com_vx"],
                "liftoff_vz_m_s": sim["takeoff"]["com_vz"],
                "planned_liftoff_vz_m_s": d["predicted"]["takeoff"]["com_vz"],
                "apex_base_z_m": v["max_base_z_m"],
                "touchdown_dx_m": sim["touchdown"]["com_x"],
                "landed_upright": v["landed_upright"],
                "knee_torque_nm": d["simulated_max"]["kfe"]["torque_nm"],
                "planned_knee_torque_nm": p["max_abs_torque_nm"]["kfe"],
                "failures": v["failures"], "solve_ms": p["solve_ms"]})
        ok = [r for r in runs if "touchdown_pitch_rad" in r]
        miss = [abs(r["touchdown_pitch_rad"] - 2 * math.pi) for r in ok if r["planned"]]
        rows.append({"knee_peak_nm": float(nm), "start": start, "seeds": seeds,
                     "planned": sum(r["planned"] for r in runs),
                     "flipped": sum(r.get("flipped", False) for r in runs),
                     "verified": sum(r["verified"] for r in runs),
                     "touchdown_rotation_miss_rad": {
                         "min": min(miss) if miss else None,
                         "median": statistics.median(miss) if miss else None},
                     "runs": runs})
def smallest(key):
    return {start: min((r["knee_peak_nm"] for r in rows if r["start"] == start and r[key]),
                       default=None) for start in ("standing", "rolling_back")}
print(json.dumps({"sweep": rows, "smallest_flipped_knee_peak_nm": smallest("flipped"),
                  "smallest_verified_knee_peak_nm": smallest("verified")}, indent=2))
PY
