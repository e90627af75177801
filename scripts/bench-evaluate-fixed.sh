#!/usr/bin/env bash
# The DE's cost per evaluation against a reference build, on the same points (issue 22, item 1:
# within 20 % of session 13's model, d1f4b43). For each preset, the reference build writes 1000
# decision vectors (planner/bench/bench_evaluate_fixed.cpp: the DE's best of seeds 1-5 and
# perturbed copies), then both builds evaluate every one of them under callgrind, counting
# instructions inside JumpModel::evaluate only. Prints one JSON line per preset: instructions
# per evaluation of each build and their ratio, and both builds' cost sums (equal when their
# models agree).
# Usage: scripts/bench-evaluate-fixed.sh <build dir> <reference build dir> [presets...]
# A reference build of d1f4b43 (which predates the bench; its source is copied in):
#   git worktree add /tmp/ref d1f4b43 && cp planner/bench/bench_evaluate_fixed.cpp \
#     /tmp/ref/planner/bench/, add its two lines of planner/CMakeLists.txt there, then
#   (cd /tmp/ref && cmake --preset release && cmake --build build/release --target bench_evaluate_fixed)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:?usage: bench-evaluate-fixed.sh <build dir> <reference build dir> [presets...]}
REF=${2:?usage: bench-evaluate-fixed.sh <build dir> <reference build dir> [presets...]}
shift 2
PRESETS=("$@")
if [ "${#PRESETS[@]}" -eq 0 ]; then PRESETS=(vertical forward forward_hw); fi
command -v valgrind > /dev/null || { echo "bench-evaluate-fixed: needs valgrind" >&2; exit 2; }
for b in "$BUILD" "$REF"; do
  [ -x "$b/bin/bench_evaluate_fixed" ] || {
    echo "bench-evaluate-fixed: $b/bin/bench_evaluate_fixed not found" >&2
    exit 2
  }
done
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
# Instructions per evaluation of one build on one preset's points.
count() {
  valgrind --tool=callgrind --callgrind-out-file="$WORK/cg.out" \
    --toggle-collect='wj::planner::JumpModel::evaluate*' \
    "$1/bin/bench_evaluate_fixed" read "$2" "$3" 1 > "$WORK/read.json" 2> "$WORK/cg.err"
  local ir
  ir=$(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$WORK/cg.err")
  [ -n "$ir" ] || { cat "$WORK/cg.err" >&2; exit 1; }
  echo "$ir $(sed -n 's/.*"points": \([0-9]*\).*"cost_sum": \([^}]*\)}.*/\1 \2/p' "$WORK/read.json")"
}
for p in "${PRESETS[@]}"; do
  "$REF/bin/bench_evaluate_fixed" write "$p" "$WORK/points_$p.txt" 1000 > /dev/null
  read -r ir_ref n_ref sum_ref < <(count "$REF" "$p" "$WORK/points_$p.txt")
  read -r ir n sum < <(count "$BUILD" "$p" "$WORK/points_$p.txt")
  /usr/bin/python3 -c '
import json, sys
p, ir, n, s, ir_ref, n_ref, s_ref = sys.argv[1:]
per, per_ref = int(ir) / int(n), int(ir_ref) / int(n_ref)
print(json.dumps({"preset": p, "points": int(n), "instructions_per_eval": round(per),
                  "reference_instructions_per_eval": round(per_ref),
                  "ratio": round(per / per_ref, 4), "cost_sum": float(s),
                  "reference_cost_sum": float(s_ref)}))' "$p" "$ir" "$n" "$sum" "$ir_ref" "$n_ref" "$sum_ref"
done
