#!/usr/bin/env bash
# deploy.deb_contents: the packages declare their dependencies, conffiles, units and binaries.
# usage: check_debs.sh OUT_DIR VERSION WITH_ROBOT_CLIENT(0|1)
set -euo pipefail
out=$1 version=$2 with_client=$3
fail() { echo "FAIL: $*" >&2; exit 1; }

deb() { # deb NAME: the one package file of that name
  local f=("$out/$1_${version}"_*.deb)
  [ -f "${f[0]}" ] || fail "no package $1_${version}_*.deb in $out"
  echo "${f[0]}"
}
field() { dpkg-deb --field "$2" "$1"; } # field NAME DEB
# Listings are captured before grep reads them: grep -q stops early, which would break the
# writer's pipe under pipefail.
has_file() { # has_file DEB PATH [MODE-PREFIX]
  local list
  list=$(dpkg-deb --contents "$1" | awk '{print $1, $NF}')
  grep -qE "^${3:-.}.* \.$2\$" <<<"$list" ||
    fail "$(basename "$1") does not hold $2${3:+ with mode $3}"
}
control_list() { dpkg-deb --ctrl-tarfile "$1" | tar -tv; }
has_conffile() {
  local list
  list=$(dpkg-deb --ctrl-tarfile "$1" | tar -xO ./conffiles 2>/dev/null || true)
  grep -qx "$2" <<<"$list" || fail "$(basename "$1") does not declare $2 as a conffile"
}
depends_on() { # depends_on DEB REGEX
  local deps
  deps=$(field Depends "$1" | tr ',' '\n' | sed 's/^ *//')
  grep -qE "^$2" <<<"$deps" || fail "$(basename "$1") Depends lacks $2 (Depends: $(field Depends "$1"))"
}

common=$(deb wheeljump-common)
server=$(deb wheeljump-planner-server)

[ "$(field Architecture "$common")" = all ] || fail "wheeljump-common is not Architecture: all"
has_file "$common" /usr/share/wheeljump/models/wheeljump.urdf
has_file "$common" /usr/share/wheeljump/models/actuators.yaml
has_file "$common" /usr/bin/wheeljump-profile -rwx
has_file "$common" /usr/share/wheeljump/systemd/wheeljump-planner-tls.conf
grep -qE ' \./postinst$' <<<"$(control_list "$common")" || fail "wheeljump-common has no postinst"

# The server: dependencies from dpkg-shlibdeps plus the common package at the same version.
depends_on "$server" "wheeljump-common \(= $version\)"
depends_on "$server" "libc6 \(>= "
depends_on "$server" "libgrpc\+\+1"
depends_on "$server" "libprotobuf[0-9]"
depends_on "$server" "libsqlite3-0"
depends_on "$server" "libyaml-cpp0"
depends_on "$server" "libsimbody"
depends_on "$server" "coinor-libipopt"
has_file "$server" /usr/bin/planner_server -rwx
has_file "$server" /usr/bin/planner_cli -rwx
has_file "$server" /lib/systemd/system/wheeljump-planner.service -rw-r--r--
for p in nuc workstation; do
  has_file "$server" /etc/wheeljump/profiles/$p/planner_server.yaml
  has_conffile "$server" /etc/wheeljump/profiles/$p/planner_server.yaml
done
for s in postinst prerm postrm; do
  grep -qE "^-rwxr-xr-x .* \./$s\$" <<<"$(control_list "$server")" ||
    fail "wheeljump-planner-server: $s missing or not executable"
done
# Every declared dependency is installed here, by name or as a virtual package that an
# installed package provides (the build machine has them all).
installed=" $(dpkg-query -W -f='${db:Status-Abbrev} ${Package} ${Provides}\n' | awk '/^ii/{$1=""; print}' |
  sed 's/([^)]*)//g; s/,/ /g' | tr -s ' \n' ' ') "
for pkg in $(field Depends "$server" | tr ',' '\n' | sed 's/(.*//; s/|.*//; s/ //g' | grep -v '^wheeljump-'); do
  case "$installed" in *" $pkg "*) ;; *) fail "dependency $pkg of wheeljump-planner-server is not installed here" ;; esac
done
# No library the binary needs is left undeclared: each one ldd resolves belongs to a package
# in Depends (or to one of their own dependencies: libc6, libstdc++6, libgcc-s1).
declared=" $(field Depends "$server" | tr ',' '\n' | sed 's/(.*//; s/ //g' | tr '\n' ' ') libc6 libstdc++6 libgcc-s1 "
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
dpkg-deb -x "$server" "$tmp"
! ldd "$tmp/usr/bin/planner_server" | grep "not found" || fail "planner_server needs a library not found here"
for lib in $(ldd "$tmp/usr/bin/planner_server" | awk '/=> \//{print $3}'); do
  # awk reads dpkg's whole answer (head -1 would close the pipe early, see above).
  owner=$(dpkg -S "$(readlink -f "$lib")" 2>/dev/null | awk -F: 'NR == 1 {print $1}') || true
  [ -z "$owner" ] && owner=$(dpkg -S "$lib" 2>/dev/null | awk -F: 'NR == 1 {print $1}') || true
  [ -n "$owner" ] || continue
  case "$declared" in *" $owner "*) ;; *) undeclared="${undeclared:-} $owner($(basename "$lib"))" ;; esac
done
echo "libraries from packages not named in Depends (pulled in by those that are):${undeclared:- none}"

if [ "$with_client" = 1 ]; then
  client=$(deb wheeljump-robot-client)
  depends_on "$client" "wheeljump-common \(= $version\)"
  depends_on "$client" "libc6 \(>= "
  has_file "$client" /usr/bin/robot_client -rwx
  has_file "$client" /lib/systemd/system/wheeljump-robot-client.service
  for p in nuc workstation; do
    has_conffile "$client" /etc/wheeljump/profiles/$p/robot_client.env
  done
else
  ! ls "$out"/wheeljump-robot-client_*.deb >/dev/null 2>&1 ||
    fail "a robot client package was built without the robot_client target"
  echo "robot_client is not built here: no wheeljump-robot-client package (expected)"
fi
dpkg-deb --info "$server"
echo "deb contents: ok"
