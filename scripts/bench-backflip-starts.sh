#!/usr/bin/env bash
# The 42 Nm backflip from perturbed start states (issue 17 items 2 and 4, docs/backflip.md,
# "From the client's start states"): the robot client asks for its flip from a state that is
# not the nominal one (still ramping to -1 m/s, pitch and joints a few mrad off, small rates).
# For each run-up speed v0 and each seed, one start state is drawn (seeded: the seed draws the
# perturbation and is the planner's seed), written as a `sim_jump --start-state` file, and
# `sim_jump --task backflip --config CONFIG --start-state FILE` plans from it and starts
# Simbody in it. Ranges (uniform): pitch +-PITCH rad, pitch rate +-PITCH_RATE rad/s, each leg
# joint (HAA, HFE, KFE) +-Q rad around the planner's standing posture and +-QD rad/s; the
# wheels roll at v0 / r. Seed 0 is the unperturbed start at each v0 (a reference row).
# Reports per v0: planned feasible, Simbody verified, and the rotation margin at touchdown
# (Simbody's rotation - (2 pi - 0.3)); per run the verifier's reasons.
# Prints one JSON document. Usage:
#   scripts/bench-backflip-starts.sh [build dir] [seeds] [config] [v0...]
# Defaults: build/release, 5, config/backflip-42nm.yaml, v0 -1.0 -0.98 -0.95.
# WJ_FLIP_PITCH (0.005), WJ_FLIP_PITCH_RATE (0.05), WJ_FLIP_Q (0.01), WJ_FLIP_QD (0.1) set the
# ranges; WJ_FLIP_SYMMETRIC=1 draws one perturbation per joint kind for all four legs.
# WJ_FLIP_WORK=DIR keeps each run's start state (V0_SEED.start.json), JSON and log there, so
# that a run can be replayed with sim_jump --start-state.
set -euo pipefail
if [ "${1:-}" = "-h" ] || [ "${1:-}" = "--help" ]; then
  sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'
  exit 0
fi
# DE threads sleep at the per-generation barrier (docs/planner.md, "Threads").
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
cd "$(dirname "$0")/.."
BUILD=${1:-build/release}
SEEDS=${2:-5}
CONFIG=${3:-config/backflip-42nm.yaml}
shift $(($# > 3 ? 3 : $#))
V0S=("$@")
if [ "${#V0S[@]}" -eq 0 ]; then V0S=(-1.0 -0.98 -0.95); fi
BIN=$BUILD/bin
[ -x "$BIN/sim_jump" ] || { echo "no $BIN/sim_jump: build it first" >&2; exit 2; }
[ -f "$CONFIG" ] || { echo "no planner settings file $CONFIG" >&2; exit 2; }
if [ -n "${WJ_FLIP_WORK:-}" ]; then
  WORK=$WJ_FLIP_WORK
  mkdir -p "$WORK"
else
  WORK=$(mktemp -d)
  trap 'rm -rf "$WORK"' EXIT
fi
for v0 in "${V0S[@]}"; do
  for seed in $(seq 0 "$SEEDS"); do
    base="$WORK/${v0}_${seed}"
    /usr/bin/python3 - "$base.start.json" "$v0" "$seed" <<'PY'
import json, os, random, sys
path, v0, seed = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
env = lambda k, d: float(os.environ.get(k, d))
pitch, pitch_rate = env("WJ_FLIP_PITCH", 0.005), env("WJ_FLIP_PITCH_RATE", 0.05)
dq, dqd = env("WJ_FLIP_Q", 0.01), env("WJ_FLIP_QD", 0.1)
symmetric = os.environ.get("WJ_FLIP_SYMMETRIC", "0") == "1"
wheel_radius = 0.085  # models/wheeljump.urdf
stand = [0.0, 1.0, -2.0]  # PlannerSettings::stand_hfe_rad / stand_kfe_rad, HAA 0
rng = random.Random(1000003 * seed + int(round(-v0 * 1000)))
u = lambda a: rng.uniform(-a, a) if seed > 0 else 0.0
state = {"v0": v0, "pitch": u(pitch), "pitch_rate": u(pitch_rate), "q": [], "qd": []}
shared = [(u(dq), u(dqd)) for _ in range(3)]
for leg in range(4):
    for kind in range(3):
        d, dd = shared[kind] if symmetric else (u(dq), u(dqd))
        state["q"].append(stand[kind] + d)
        state["qd"].append(dd)
    state["q"].append(0.0)
    state["qd"].append(v0 / wheel_radius)
json.dump(state, open(path, "w"))
PY
    nice "$BIN/sim_jump" --task backflip --config "$CONFIG" --start-state "$base.start.json" \
      --seed "$((seed > 0 ? seed : 1))" --threads 2 --json > "$base.json" 2> "$base.log" || true
  done
done
/usr/bin/python3 - "$WORK" "$SEEDS" "$CONFIG" "${V0S[@]}" <<'PY'
import json, math, statistics, sys
work, seeds, config, v0s = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
need = 2 * math.pi - 0.3
rows = []
for v0 in v0s:
    runs = []
    for s in range(0, seeds + 1):
        base = f"{work}/{v0}_{s}"
        start = json.load(open(base + ".start.json"))
        run = {"seed": s, "start": {k: start[k] for k in ("pitch", "pitch_rate")},
               "max_abs_dq_rad": max(abs(q - n) for q, n in
                                     zip(start["q"], [0.0, 1.0, -2.0, 0.0] * 4)),
               "max_abs_leg_qd_rad_s": max(abs(x) for i, x in enumerate(start["qd"]) if i % 4 != 3)}
        try:
            d = json.load(open(base + ".json"))
        except Exception:
            run.update(planned=False, verified=False,
                       error=open(base + ".log").read().strip()[-300:])
            runs.append(run)
            continue
        p, sim, v = d["plan"], d["simulated"], d["verification"]
        planned = bool(p["feasible"]) and "target is met" in p["summary"]
        td = sim["touchdown"]["pitch"]
        run.update(planned=planned, verified=planned and bool(v["passed"]),
                   planned_touchdown_pitch_rad=d["predicted"]["touchdown"]["pitch"],
                   touchdown_pitch_rad=td, rotation_margin_rad=td - need,
                   final_rotation_rad=v["final_rotation_rad"],
                   max_envelope_ratio=v["max_envelope_ratio"],
                   worst_envelope_joint=v["worst_envelope_joint"],
                   landed_upright=v["landed_upright"], failures=v["failures"],
                   reasons=v["reasons"], solve_ms=p["solve_ms"])
        runs.append(run)
    perturbed = [r for r in runs if r["seed"] > 0]
    margins = [r["rotation_margin_rad"] for r in perturbed if r["planned"]]
    rows.append({"v0": float(v0), "seeds": seeds,
                 "unperturbed": {k: runs[0].get(k) for k in
                                 ("planned", "verified", "rotation_margin_rad")},
                 "planned": sum(r["planned"] for r in perturbed),
                 "verified": sum(r["verified"] for r in perturbed),
                 "rotation_margin_rad": {
                     "min": min(margins) if margins else None,
                     "median": statistics.median(margins) if margins else None,
                     "max": max(margins) if margins else None},
                 "runs": runs})
allp = [r for row in rows for r in row["runs"] if r["seed"] > 0]
print(json.dumps({"config": config, "need_rad": need,
                  "total": {"runs": len(allp), "planned": sum(r["planned"] for r in allp),
                            "verified": sum(r["verified"] for r in allp)},
                  "sweep": rows}, indent=2))
PY
