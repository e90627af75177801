#!/usr/bin/env bash
# deploy.systemd_verify: `systemd-analyze verify` accepts both units as installed in the scratch
# root (fixture wj_root), with the binaries they start. A unit whose package is not built here
# (the robot client without its target) is checked from the source tree against a stand-in
# executable, in a root of its own. Warnings count as failures.
# usage: verify_units.sh ROOT SOURCE_DIR
set -euo pipefail
shopt -s nullglob
root=$1 src=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v systemd-analyze >/dev/null || fail "systemd-analyze not found (package systemd)"

# systemd-analyze --root needs the standard targets the units are ordered against. They are
# copied from this machine for the check and removed afterwards (the purge test that follows
# checks that nothing but the packages' files was in the root).
seeded=()
cleanup() { rm -f "${seeded[@]}"; }
trap cleanup EXIT
seed_targets() {
  mkdir -p "$1/lib/systemd/system"
  for t in /lib/systemd/system/*.target /lib/systemd/system/*.slice; do
    local dest
    dest="$1/lib/systemd/system/$(basename "$t")"
    if [ ! -e "$dest" ]; then
      cp -a "$t" "$dest"
      seeded+=("$dest")
    fi
  done
}

verify() { # verify ROOT UNIT MAX_EXPOSURE (systemd-analyze security's 0-10 scale, x10)
  local log
  log=$(systemd-analyze verify --root="$1" "/lib/systemd/system/$2" 2>&1) || { echo "$log"; fail "$2 rejected"; }
  # verify exits 0 on some problems it only reports: any output is a finding.
  [ -z "$log" ] || { echo "$log"; fail "$2: systemd-analyze reported the above"; }
  # The sandbox must stay as tight as designed (planner 1.5, robot client 2.2 when written).
  log=$(systemd-analyze security --offline=true --root="$1" --threshold="$3" "$2" 2>&1) ||
    { echo "$log" | grep -E "✗|Overall"; fail "$2: exposure above $(($3 / 10)).$(($3 % 10))"; }
  echo "$2: accepted ($1); $(echo "$log" | grep -o 'Overall exposure level.*' | sed 's/ [^ ]*$//')"
}

seed_targets "$root"
[ -f "$root/lib/systemd/system/wheeljump-planner.service" ] || fail "planner unit not installed in $root"
verify "$root" wheeljump-planner.service 20

if [ -f "$root/lib/systemd/system/wheeljump-robot-client.service" ]; then
  verify "$root" wheeljump-robot-client.service 30
else
  alt="$root-unit-check"
  rm -rf "$alt"
  seed_targets "$alt"
  mkdir -p "$alt/usr/bin"
  printf '#!/bin/sh\nexit 0\n' >"$alt/usr/bin/robot_client"
  chmod 755 "$alt/usr/bin/robot_client"
  cp "$src/deploy/systemd/wheeljump-robot-client.service" "$alt/lib/systemd/system/"
  verify "$alt" wheeljump-robot-client.service 30
  rm -rf "$alt"
fi

# The TLS drop-in of the workstation profile, applied to the installed planner unit.
mkdir -p "$root/etc/systemd/system/wheeljump-planner.service.d"
cp "$root/usr/share/wheeljump/systemd/wheeljump-planner-tls.conf" \
  "$root/etc/systemd/system/wheeljump-planner.service.d/50-tls.conf"
verify "$root" wheeljump-planner.service 20
rm -rf "$root/etc/systemd/system/wheeljump-planner.service.d"
echo "systemd units: ok"
