"""sim.backflip_42nm: the 42 Nm backflip of docs/backflip.md ("A 42 Nm flip, verified in
Simbody"). Runs `sim_jump --task backflip --v0 -1.0 --seed 1 --config
config/backflip-42nm.yaml --json` on the real robot (models/actuators.yaml, 42 Nm at every leg
joint) and requires: the plan feasible, Simbody's run passing the verifier, the knee's limit
42 Nm in both, and a full flip by issue 17's criterion (at least 2 pi - 0.3 rad turned at
touchdown). The same from a start like the robot client's (docs/backflip.md, "From perturbed
starts": `--start-state`, still ramping at -0.97 m/s, pitch, joints and rates a few mrad off,
independently per leg), and a start-state file with an unknown key refused, naming it. Two plans
and two Simbody runs: about 2-6 s.

usage: check_backflip_42nm.py SIM_JUMP CONFIG
"""
import json
import math
import os
import subprocess
import sys
import tempfile

sim_jump, config = sys.argv[1], sys.argv[2]
problems = []
WHEEL_RADIUS = 0.085  # models/wheeljump.urdf
# The client's request state of docs/backflip.md, session 14 (noise seed 6), rounded: jointIndex
# order (LF, RF, LH, RH; HAA, HFE, KFE, wheel each).
CLIENT_START = {
    "v0": -0.97, "pitch": -0.004, "pitch_rate": 0.03,
    "q": [0.003, 1.006, -1.996, 0.0, -0.002, 1.004, -1.998, 0.0,
          0.001, 1.008, -1.994, 0.0, -0.003, 1.005, -1.995, 0.0],
    "qd": [0.02, 0.09, -0.05, -0.97 / WHEEL_RADIUS, -0.03, 0.06, -0.08, -0.97 / WHEEL_RADIUS,
           0.01, -0.04, 0.07, -0.97 / WHEEL_RADIUS, 0.0, 0.05, -0.06, -0.97 / WHEEL_RADIUS]}


def check_flip(name, start_args):
    out = subprocess.run([sim_jump, "--task", "backflip", "--seed", "1", "--threads", "2",
                          "--config", config, "--json"] + start_args,
                         capture_output=True, text=True)
    if out.returncode not in (0, 3):
        problems.append(f"{name}: sim_jump failed ({out.returncode}): {out.stderr}")
        return
    check_run(name, out, json.loads(out.stdout))


def check_run(name, out, doc):
    v = doc["verification"]
    if not doc["plan"]["feasible"]:
        problems.append(f"{name}: the plan is infeasible: {doc['plan']['summary']}")
    if not v["passed"]:
        problems.append(f"{name}: Simbody's run fails the verifier: " + "; ".join(v["reasons"]))
    if v["actuators_file"] != "actuators.yaml":
        problems.append(f"{name}: the robot is {v['actuators_file']}, not actuators.yaml")
    knee = doc["simulated_max"]["kfe"]["torque_limit_nm"]
    if abs(knee - 42.0) > 1e-9:
        problems.append(f"{name}: the knee's limit is {knee} Nm, not 42")
    turned = doc["simulated"]["touchdown"]["pitch"]
    need = 2.0 * math.pi - 0.3
    if turned < need:
        problems.append(f"{name}: Simbody turned {turned:.3f} rad at touchdown, less than {need:.3f}")
    if out.returncode != (0 if v["passed"] else 3):
        problems.append(f"{name}: exit status {out.returncode} does not match the verdict")
    print(f"{name}: plan feasible {doc['plan']['feasible']}, verified {v['passed']}, "
          f"{turned:.3f} rad at touchdown (need {need:.3f})")


check_flip("rolling back at 1 m/s", ["--v0", "-1.0"])
with tempfile.TemporaryDirectory() as tmp:
    start = os.path.join(tmp, "client_start.json")
    with open(start, "w") as f:
        json.dump(CLIENT_START, f)
    check_flip("the client's start", ["--start-state", start])
    bad = os.path.join(tmp, "bad_start.json")
    with open(bad, "w") as f:
        json.dump(dict(CLIENT_START, roll=0.0), f)
    out = subprocess.run([sim_jump, "--task", "backflip", "--config", config, "--start-state", bad],
                         capture_output=True, text=True)
    if out.returncode != 2 or "unknown key 'roll'" not in out.stderr:
        problems.append(f"a start state with an unknown key: exit {out.returncode}, "
                        f"stderr {out.stderr.strip()!r} (want 2, naming 'roll')")
for p in problems:
    print("FAIL:", p)
sys.exit(1 if problems else 0)
