#!/usr/bin/env bash
# deploy.profiles: every planner_server profile in deploy/profiles passes the server's strict
# reader (planner_server --check-config), and the reader does refuse a profile with an unknown
# key, a missing key or a value out of range (exit 2, naming the key).
# usage: check_profiles.sh PLANNER_SERVER SOURCE_DIR WORK_DIR
set -euo pipefail
server=$1 src=$2 work=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
mkdir -p "$work"
unset WJ_MODELS_DIR
n=0
for f in "$src"/deploy/profiles/*/planner_server.yaml; do
  msg=$("$server" --check-config "$f") || fail "$f rejected"
  echo "$msg"
  # A binary in the build tree reads the source tree's models (models_dir: "").
  case "$msg" in *"from $src/models)") ;; *) fail "build-tree binary did not read $src/models" ;; esac
  n=$((n + 1))
done
[ "$n" -ge 2 ] || fail "expected the nuc and workstation profiles, found $n"
for p in nuc workstation; do
  [ -f "$src/deploy/profiles/$p/planner_server.yaml" ] || fail "profile $p has no planner_server.yaml"
  [ -f "$src/deploy/profiles/$p/robot_client.env" ] || fail "profile $p has no robot_client.env"
done

# Profile rules the units and docs rely on.
nuc="$src/deploy/profiles/nuc/planner_server.yaml"
ws="$src/deploy/profiles/workstation/planner_server.yaml"
grep -q '^listen: "127.0.0.1:' "$nuc" || fail "nuc must listen on loopback"
grep -q '^listen: "0.0.0.0:' "$ws" || fail "workstation must listen on all interfaces"
grep -qE '^  mode: (tls|mutual_tls)' "$ws" || fail "workstation must use TLS"
for f in "$nuc" "$ws"; do
  grep -q '^  path: "/var/lib/wheeljump-planner/' "$f" || fail "$f: cache not in the StateDirectory"
done
grep -q '^WHEELJUMP_PLANNER=127.0.0.1:' "$src/deploy/profiles/nuc/robot_client.env" || fail "nuc robot client must use the loopback service"

expect_refused() { # expect_refused NAME SED-SCRIPT WORD-IN-MESSAGE
  sed "$2" "$nuc" >"$work/$1.yaml"
  cmp -s "$nuc" "$work/$1.yaml" && fail "$1: the edit did not change the file"
  set +e
  msg=$("$server" --check-config "$work/$1.yaml" 2>&1)
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "$1: exit $rc, expected 2 ($msg)"
  case "$msg" in *"$3"*) ;; *) fail "$1: message does not name $3: $msg" ;; esac
  echo "refused as expected: $msg"
}
expect_refused unknown_key '/^  de_threads:/a\  de_threadz: 2' "unknown key 'planner.de_threadz'"
expect_refused missing_key '/^  hit_queue:/d' hit_queue
expect_refused out_of_range 's/^  de_threads: .*/  de_threads: 0/' de_threads
expect_refused insecure_open 's/^listen: .*/listen: "0.0.0.0:50051"/' allow_insecure_non_loopback
echo "profiles: ok"
