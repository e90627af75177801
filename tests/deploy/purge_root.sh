#!/usr/bin/env bash
# deploy.purge_root: removes and purges the packages from the scratch root (fixture cleanup):
# the maintainer scripts run, conffiles go, and nothing of the packages is left.
# usage: purge_root.sh ROOT
set -euo pipefail
root=$1
fail() { echo "FAIL: $*" >&2; exit 1; }
[ -d "$root/var/lib/dpkg" ] || fail "no scratch root at $root"
opts=(--root="$root" --force-depends --force-script-chrootless --log=/dev/null)
[ "$(id -u)" -eq 0 ] || opts+=(--force-not-root)
mapfile -t pkgs < <(dpkg --root="$root" -l 'wheeljump-*' | awk '/^ii/{print $2}')
[ "${#pkgs[@]}" -ge 2 ] || fail "expected the wheeljump packages in the scratch root, found: ${pkgs[*]:-none}"
dpkg "${opts[@]}" --remove "${pkgs[@]}"
[ -f "$root/etc/wheeljump/profiles/nuc/planner_server.yaml" ] || fail "remove deleted a conffile (only purge should)"
[ ! -e "$root/usr/bin/planner_server" ] || fail "remove left /usr/bin/planner_server"
dpkg "${opts[@]}" --purge "${pkgs[@]}"
left=$(find "$root/etc" "$root/usr" "$root/lib" -mindepth 1 ! -type d 2>/dev/null | grep -v '^$' || true)
[ -z "$left" ] || fail "left after purge: $left"
[ ! -e "$root/var/lib/wheeljump-planner" ] || fail "purge left the cache"
echo "remove and purge: ok"
