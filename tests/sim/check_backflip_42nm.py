"""sim.backflip_42nm: the 42 Nm backflip of docs/backflip.md ("A 42 Nm flip, verified in
Simbody"). Runs `sim_jump --task backflip --v0 -1.0 --seed 1 --config
config/backflip-42nm.yaml --json` on the real robot (models/actuators.yaml, 42 Nm at every leg
joint) and requires: the plan feasible, Simbody's run passing the verifier, the knee's limit
42 Nm in both, and a full flip by issue 17's criterion (at least 2 pi - 0.3 rad turned at
touchdown). One plan and one Simbody run: about 1-3 s.

usage: check_backflip_42nm.py SIM_JUMP CONFIG
"""
import json
import math
import subprocess
import sys

sim_jump, config = sys.argv[1], sys.argv[2]
out = subprocess.run([sim_jump, "--task", "backflip", "--v0", "-1.0", "--seed", "1", "--threads",
                      "2", "--config", config, "--json"], capture_output=True, text=True)
if out.returncode not in (0, 3):
    sys.exit(f"sim_jump failed ({out.returncode}): {out.stderr}")
doc = json.loads(out.stdout)
v = doc["verification"]
problems = []
if not doc["plan"]["feasible"]:
    problems.append(f"the plan is infeasible: {doc['plan']['summary']}")
if not v["passed"]:
    problems.append("Simbody's run fails the verifier: " + "; ".join(v["reasons"]))
if v["actuators_file"] != "actuators.yaml":
    problems.append(f"the robot is {v['actuators_file']}, not actuators.yaml")
knee = doc["simulated_max"]["kfe"]["torque_limit_nm"]
if abs(knee - 42.0) > 1e-9:
    problems.append(f"the knee's limit is {knee} Nm, not 42")
turned = doc["simulated"]["touchdown"]["pitch"]
need = 2.0 * math.pi - 0.3
if turned < need:
    problems.append(f"Simbody turned {turned:.3f} rad at touchdown, less than {need:.3f}")
if out.returncode != (0 if v["passed"] else 3):
    problems.append(f"exit status {out.returncode} does not match the verdict")
for p in problems:
    print("FAIL:", p)
print(f"plan feasible {doc['plan']['feasible']}, verified {v['passed']}, "
      f"{turned:.3f} rad at touchdown (need {need:.3f})")
sys.exit(1 if problems else 0)
