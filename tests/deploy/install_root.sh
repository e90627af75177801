#!/usr/bin/env bash
# deploy.install_root: installs the packages with dpkg into a scratch root (fixture wj_root) and
# runs the installed planner_server from there: --help, --check-config of every installed
# profile (the models must be found beside the binary), and a start/SIGTERM cycle.
# dpkg runs the maintainer scripts without chroot (--force-script-chrootless) with DPKG_ROOT set;
# the scripts then only touch files under DPKG_ROOT, never the running system.
# usage: install_root.sh OUT_DIR ROOT
set -euo pipefail
out=$1 root=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
unset WJ_MODELS_DIR

rm -rf "$root"
mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates" "$root/var/lib/dpkg/triggers"
touch "$root/var/lib/dpkg/status" "$root/var/lib/dpkg/available"
opts=(--root="$root" --force-depends --force-script-chrootless --log=/dev/null)
[ "$(id -u)" -eq 0 ] || opts+=(--force-not-root)

debs=("$out"/wheeljump-*.deb)
dpkg "${opts[@]}" -i "${debs[@]}"
dpkg --root="$root" -l | grep '^ii' | awk '{print $2, $3}'
for d in "${debs[@]}"; do
  name=$(dpkg-deb --field "$d" Package)
  status=$(dpkg --root="$root" -s "$name")
  grep -q "^Status: install ok installed" <<<"$status" || fail "$name is not installed"
done

# Files where the units and the documentation say they are.
for f in usr/bin/planner_server usr/bin/planner_cli usr/bin/wheeljump-profile \
  usr/share/wheeljump/models/wheeljump.urdf lib/systemd/system/wheeljump-planner.service \
  etc/wheeljump/profiles/nuc/planner_server.yaml etc/wheeljump/profiles/workstation/planner_server.yaml \
  etc/wheeljump/profiles/nuc/planner_settings.yaml etc/wheeljump/profiles/workstation/planner_settings.yaml \
  etc/wheeljump/profiles/nuc/jump_executor.yaml etc/wheeljump/profiles/workstation/jump_executor.yaml; do
  [ -e "$root/$f" ] || fail "/$f is not installed"
done
# postinst of wheeljump-common selected the nuc profile.
[ "$(readlink "$root/etc/wheeljump/active")" = profiles/nuc ] || fail "/etc/wheeljump/active does not point at profiles/nuc"
# The installed binaries have no library path into the build tree.
build=$(cd "$out/../../.." && pwd)
for b in planner_server planner_cli; do
  dynamic=$(readelf -d "$root/usr/bin/$b")
  ! grep -E 'RPATH|RUNPATH' <<<"$dynamic" | grep -qF "$build" || fail "$b has a build-tree RUNPATH"
done

server="$root/usr/bin/planner_server"
help=$("$server" --help)
grep -q -- "--check-config" <<<"$help" || fail "planner_server --help does not list --check-config"
for p in nuc workstation; do
  msg=$("$server" --check-config "$root/etc/wheeljump/profiles/$p/planner_server.yaml") ||
    fail "profile $p: --check-config exit $?"
  echo "$msg"
  case "$msg" in *"from $root/usr/share/wheeljump/models"*) ;; *) fail "profile $p: models not read from the installed tree" ;; esac
done
# The active profile through the symlink the unit uses.
"$server" --check-config "$root/etc/wheeljump/active/planner_server.yaml" >/dev/null || fail "active profile rejected"

# Start the installed binary on the nuc profile (cache moved into the scratch root, an ephemeral
# port) and stop it with SIGTERM, as systemd would. The copy is elsewhere: its planner settings
# file (a path relative to the profile) is named absolutely.
sed -e "s|/var/lib/wheeljump-planner|$root/var/lib/wheeljump-planner|" \
  -e "s|^  settings_file: \"planner_settings.yaml\"|  settings_file: \"$root/etc/wheeljump/profiles/nuc/planner_settings.yaml\"|" \
  -e "s|^  jump_executor_file: \"jump_executor.yaml\"|  jump_executor_file: \"$root/etc/wheeljump/profiles/nuc/jump_executor.yaml\"|" \
  "$root/etc/wheeljump/profiles/nuc/planner_server.yaml" >"$root/run-nuc.yaml"
mkdir -p "$root/var/lib/wheeljump-planner"
log="$root/run-nuc.log"
"$server" --config "$root/run-nuc.yaml" --listen 127.0.0.1:0 >"$log" 2>&1 &
pid=$!
for _ in $(seq 1 300); do
  grep -q "planner_server listening on" "$log" && break
  kill -0 "$pid" 2>/dev/null || { cat "$log"; fail "installed planner_server exited at start"; }
  sleep 0.1
done
grep -q "planner_server listening on" "$log" || { kill "$pid"; cat "$log"; fail "no listening line in 30 s"; }
addr=$(sed -n 's/^planner_server listening on //p' "$log")
"$root/usr/bin/planner_cli" --help >/dev/null || fail "planner_cli --help"
"$root/usr/bin/planner_cli" --target "$addr" stats >"$root/stats.txt" 2>&1 || { cat "$root/stats.txt"; kill "$pid"; fail "planner_cli stats against the installed server"; }
kill -TERM "$pid"
wait "$pid" || fail "planner_server exit status $? after SIGTERM"
grep -q "planner_server stopped" "$log" || fail "no clean stop"
[ -f "$root/var/lib/wheeljump-planner/plan_cache.sqlite" ] || fail "no cache file in the state directory"

# The robot client, when its package was built: the binary runs, and every file its unit reads
# through /etc/wheeljump/active exists in both profiles.
if [ -e "$root/usr/bin/robot_client" ]; then
  "$root/usr/bin/robot_client" --help >/dev/null || fail "robot_client --help"
  for p in nuc workstation; do
    for f in robot_client.env robot_client.yaml jump_executor.yaml; do
      [ -f "$root/etc/wheeljump/profiles/$p/$f" ] || fail "profile $p lacks $f"
    done
  done
  [ -f "$root/lib/systemd/system/wheeljump-robot-client.service" ] || fail "robot client unit not installed"
fi

# wheeljump-profile switches the profile and the TLS drop-in, in the scratch root.
profiles=$(WHEELJUMP_ROOT="$root" "$root/usr/bin/wheeljump-profile" list)
grep -qx workstation <<<"$profiles" || fail "profile list"
WHEELJUMP_ROOT="$root" "$root/usr/bin/wheeljump-profile" workstation 2>/dev/null
[ "$(readlink "$root/etc/wheeljump/active")" = profiles/workstation ] || fail "switch to workstation"
[ -f "$root/etc/systemd/system/wheeljump-planner.service.d/50-tls.conf" ] || fail "no TLS drop-in"
if WHEELJUMP_ROOT="$root" "$root/usr/bin/wheeljump-profile" nosuchprofile 2>/dev/null; then fail "unknown profile accepted"; fi
WHEELJUMP_ROOT="$root" "$root/usr/bin/wheeljump-profile" nuc
[ ! -e "$root/etc/systemd/system/wheeljump-planner.service.d/50-tls.conf" ] || fail "TLS drop-in left for nuc"
[ "$(WHEELJUMP_ROOT="$root" "$root/usr/bin/wheeljump-profile")" = nuc ] || fail "active profile not reported"
echo "scratch-root install: ok"
