#!/usr/bin/env bash
# The planner's take-off against Simbody (issue 22) over a grid: forward_hw, forward and
# vertical at their own run-up speed and at two others, planner seeds 1..N (default 3).
# Prints one JSON line per case (planned and simulated lift-off time, CoM velocity, angular
# momentum about the CoM, CoM apex, touchdown pitch and dx; see tests/sim/
# test_takeoff_fidelity.cpp), then a summary of how many cases meet each of issue 22's
# targets: |dv| <= 1 % of the speed, |dH| <= 3 % (the plan's flight momentum: the push's at t2
# plus the unloading tail's), touchdown pitch <= 0.03 rad, apex <= 1 cm, touchdown dx <= 3 cm.
# Usage: scripts/bench-takeoff-fidelity.sh [build dir] [seeds] [stance momentum: 0 | 1]
#        [unloading tail: 1 | 0 (the planner's takeoff_unload_s = 0)]
# WJ_FIDELITY_SPEED_LOOP=1: the take-off's wheels with session 16's law (the speed gain on the
# whole error to the plan's no-slip rate; ExecutorSettings::takeoff_wheel_kd), for a before.
# WJ_FIDELITY_OPEN_LOOP=1: session 19's executor (no take-off momentum feedback, flight gains
# 80 / 2; ExecutorSettings::takeoff_momentum_kp, flight_kp), for a before.
# WJ_FIDELITY_REFERENCE_INTEGRATOR=1: Simbody with its reference integrator (Runge-Kutta-Merson
# at 1e-5) in place of the verifier's 1 ms semi-explicit Euler step; the difference between
# the two runs is the simulation's own error on each figure.
# WJ_FIDELITY_CONTACT_STIFFNESS=<Pa>: Simbody's contact modulus in place of 8e6.
# WJ_FIDELITY_CONTACT_DISSIPATION=<s/m>: Simbody's contact dissipation (Hunt-Crossley c) in
# place of 0.8.
# WJ_FIDELITY_TAKEOFF_GAINS=kp,kd: the take-off's joint gains in place of 150,3.
# WJ_FIDELITY_MOMENTUM_GAINS=kp,kd: the executor's take-off momentum feedback gains
# (ExecutorSettings::takeoff_momentum_kp, _kd) in place of 150,0.5.
# WJ_FIDELITY_TYRE_MODULUS=<Pa>: the planner's tyre sink (physics.tyre_contact_modulus_pa) in
# place of the rigid wheel; Simbody's wheels are 2.828e6 (docs/takeoff-fidelity.md).
# WJ_FIDELITY_CORRECTION=<rounds>: the plans with the lift-off correction (sim::
# planWithLiftOffCorrection, at most that many plans after the first; docs/planner.md, "The
# lift-off correction"); flight_momentum_3pct compares the flight's momentum with the wheels as
# point masses (planner::JumpEvent::momentum), the plan's own against Simbody's.
# WJ_FIDELITY_FLIGHT_GAINS=kp,kd: the executor's flight leg gains in place of 300,6.
# WJ_FIDELITY_SAMPLES_FLIGHT=<n>: the planner's flight attitude table (sampling.samples_flight)
# with n samples in place of 24.
# WJ_FIDELITY_FLIGHT_FEEDFORWARD=1: the flight's feed-forward and the drive-limited tuck
# (physics.flight_feedforward, postures.drive_limited_tuck; docs/planner.md).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build/release}
BIN=$BUILD/bin/sim_test_takeoff_fidelity
[ -x "$BIN" ] || { echo "bench-takeoff-fidelity: $BIN not found" >&2; exit 2; }
OUT=$(WJ_FIDELITY_CORRECTION=${WJ_FIDELITY_CORRECTION:-0} WJ_FIDELITY_BENCH=1 WJ_FIDELITY_SEEDS=${2:-3} WJ_FIDELITY_STANCE_MOMENTUM=${3:-0} WJ_FIDELITY_NO_TAIL=$([ "${4:-1}" = 0 ] && echo 1 || echo 0) "$BIN" --gtest_filter='*BenchGrid' | grep '^{')
echo "$OUT"
echo "$OUT" | /usr/bin/python3 -c '
import json, math, sys
rows = [json.loads(l) for l in sys.stdin if l.strip()]
def ok(r):
    (vxp, vxs), (vzp, vzs) = r["vx"], r["vz"]
    hp, hs = r["h_plan_flight"], r["h"][1]
    return {"velocity_1pct": math.hypot(vxs - vxp, vzs - vzp) <= 0.01 * math.hypot(vxp, vzp),
            "momentum_3pct": abs(hs - hp) <= 0.03 * abs(hp),
            "flight_momentum_3pct": abs(r["h_flight"][1] - r["h_flight"][0]) <= 0.03 * abs(r["h_flight"][0]),
            "touchdown_pitch_0.03": abs(r["td_pitch"][1] - r["td_pitch"][0]) <= 0.03,
            "apex_1cm": abs(r["apex"][1] - r["apex"][0]) <= 0.01,
            "touchdown_dx_3cm": abs(r["td_dx"][1] - r["td_dx"][0]) <= 0.03}
summary = {}
for r in rows:
    for k, v in ok(r).items():
        summary.setdefault(k, 0)
        summary[k] += int(v)
print(json.dumps({"cases": len(rows), "meeting": summary, "passed": sum(r["passed"] for r in rows)}))
# Where Simbody leaves the plan by t2 (medians per preset; docs/planner.md, "Where Simbody'"'"'s
# momentum at t2 goes"): H (Simbody - plan) at the last sample before t2 split by the base'"'"'s
# pitch rate, the legs (their joint rates and the posture), the wheels'"'"' spin, and the sample
# instant (the plan'"'"'s H at t2 less at the sample); the pitch-rate error split by the joints'"'"'
# rates, the contact and the posture; the ground'"'"'s moment impulse over the push, Simbody less
# the plan, by the pairs'"'"' normal forces, the horizontal forces and the levers, and the plan'"'"'s
# own imbalance (its H change less its forces'"'"' impulse).
med = lambda v: sorted(v)[len(v) // 2] if len(v) % 2 else 0.5 * sum(sorted(v)[len(v) // 2 - 1:len(v) // 2 + 1])
legs = ("config", "hfe_f", "kfe_f", "hfe_h", "kfe_h", "haa")
out = {}
for task in dict.fromkeys(r["task"] for r in rows):
    rs = [r for r in rows if r["task"] == task and r["h_parts"] and r["h_impulse"]]
    last = [r["h_parts"][-1] for r in rs]
    imp = [r["h_impulse"] for r in rs]
    col = {"dh_t2": [r["h_sim_t2"] - r["h"][0] for r in rs],
           "same_instant": [p["total"] for p in last], "base": [p["base"] for p in last],
           "legs": [sum(p[k] for k in legs) for p in last], "kfe_f": [p["kfe_f"] for p in last],
           "wheel": [p["wheel"] for p in last], "instant": [-r["h_plan_instant"] for r in rs],
           "rate": [p["pitch_rate"]["measured"] for p in last],
           "rate_joints": [p["pitch_rate"]["joints"] for p in last],
           "rate_contact": [p["pitch_rate"]["contact"] for p in last],
           "rate_posture": [p["pitch_rate"]["posture"] for p in last],
           "impulse": [i["impulse"][1] - i["impulse"][0] for i in imp],
           "fz_front": [i["fz_front"] for i in imp], "fz_hind": [i["fz_hind"] for i in imp],
           "fx": [i["fx"] for i in imp], "lever": [i["lever"] for i in imp],
           "plan_imbalance": [i["dh"][0] - i["impulse"][0] for i in imp]}
    out[task] = {k: round(med(v), 3) for k, v in col.items()}
print(json.dumps({"momentum_decomposition_medians": out}))
# The touchdown pitch error (Simbody - plan) split, medians per preset: the flight momentum'"'"'s
# error over Simbody'"'"'s pitch inertia to its touchdown ("momentum"), the attitude at Simbody'"'"'s
# lift-off ("lift_off"), the plan'"'"'s pitch at Simbody'"'"'s touchdown instant less at its own
# ("instant"), and what is left: the legs'"'"' motion in flight, Simbody'"'"'s tracking against the
# plan'"'"'s ("flight_legs"; docs/planner.md, "The touchdown pitch'"'"'s two errors").
out = {}
for task in dict.fromkeys(r["task"] for r in rows):
    rs = [r for r in rows if r["task"] == task]
    err = [r["td_pitch"][1] - r["td_pitch"][0] for r in rs]
    parts = {"error": err, "momentum": [r["td_pitch_from_dh"] for r in rs],
             "lift_off": [r["lift_pitch_error"] for r in rs],
             "instant": [r["td_instant_pitch"] for r in rs]}
    parts["flight_legs"] = [e - m - l - i for e, m, l, i in
                            zip(err, parts["momentum"], parts["lift_off"], parts["instant"])]
    out[task] = {k: round(med(v), 3) for k, v in parts.items()}
print(json.dumps({"touchdown_pitch_split_medians": out}))
'
