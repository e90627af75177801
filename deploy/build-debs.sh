#!/usr/bin/env bash
# Builds the Debian packages of wheeljump on this machine (Debian 12):
#   bash deploy/build-debs.sh            -> build/debs/wheeljump-*.deb
# then install them with
#   sudo apt install ./build/debs/*.deb
# It installs the build dependencies (deploy/install-deps.sh), configures an optimised build
# without tests in build/deb, builds the packaged binaries only (CMake's target wj_packaged),
# runs CPack (DEB), and checks that every package the build declares (wj_deb_packages.txt) was
# made.
#
# Options (each also an environment variable; the option wins):
#   --build-dir DIR   BUILD_DIR      build folder (default build/deb)
#   --out-dir DIR     OUT_DIR        where the .deb files go; emptied first (default build/debs)
#   --jobs N          JOBS           parallel build jobs (default: all cores)
#   --components L    WJ_COMPONENTS  components to configure (default planner;sim;server;robot_client)
#   --no-deps         WJ_NO_DEPS=1   do not run deploy/install-deps.sh
#   --configured      WJ_CONFIGURED=1  the build folder is already configured (for example the
#                     test build): build and package it as it is, without reconfiguring
# The deployment tests (tests/deploy, deploy.cpack) run this script with --no-deps --configured
# on the test build, so the command the docs give is the command CI runs.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
build=${BUILD_DIR:-build/deb}
out=${OUT_DIR:-build/debs}
jobs=${JOBS:-$(nproc)}
components=${WJ_COMPONENTS:-planner;sim;server;robot_client}
no_deps=${WJ_NO_DEPS:-0}
configured=${WJ_CONFIGURED:-0}

usage() { sed -n '2,21p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
die() {
  echo "build-debs: $*" >&2
  exit 2
}
need_value() { [ $# -ge 2 ] && [ -n "$2" ] || die "$1 needs a value (see --help)"; }
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) need_value "$@"; build=$2; shift 2 ;;
    --out-dir) need_value "$@"; out=$2; shift 2 ;;
    --jobs) need_value "$@"; jobs=$2; shift 2 ;;
    --components) need_value "$@"; components=$2; shift 2 ;;
    --no-deps) no_deps=1; shift ;;
    --configured) configured=1; shift ;;
    -h | --help) usage; exit 0 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
[[ $jobs =~ ^[1-9][0-9]*$ ]] || die "--jobs must be a positive integer, got '$jobs'"

[ "$no_deps" = 1 ] || bash deploy/install-deps.sh
if [ "$configured" = 1 ]; then
  [ -f "$build/wj_deb_packages.txt" ] ||
    die "--configured: $build is not a configured wheeljump build (no wj_deb_packages.txt)"
else
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_INSTALL_PREFIX=/usr \
    -DWJ_BUILD_TESTS=OFF -DWJ_BUILD_BENCHMARKS=OFF -DWJ_COMPONENTS="$components"
fi
cmake --build "$build" -j "$jobs" --target wj_packaged

rm -rf "$out"
mkdir -p "$out"
cpack -G DEB --config "$build/CPackConfig.cmake" -B "$out" >"$out/cpack.log" 2>&1 || {
  cat "$out/cpack.log" >&2
  die "CPack failed (log above)"
}
rm -rf "$out/_CPack_Packages" "$out/cpack.log"

# Every package the build declares, and nothing else, is in the output folder.
mapfile -t expected <"$build/wj_deb_packages.txt"
[ "${#expected[@]}" -gt 0 ] || die "$build/wj_deb_packages.txt names no package"
for name in "${expected[@]}"; do
  made=("$out/${name}_"*.deb)
  [ -f "${made[0]}" ] || die "CPack did not make the package $name (expected $out/${name}_*.deb)"
done
debs=("$out"/*.deb)
[ "${#debs[@]}" -eq "${#expected[@]}" ] ||
  die "CPack made ${#debs[@]} packages, the build declares ${#expected[@]}: ${expected[*]}"

echo
echo "packages:"
printf '%s\n' "${debs[@]}"
case "$out" in /*) prefix="" ;; *) prefix="./" ;; esac
echo "install them with: sudo apt install $(printf "$prefix%s " "${debs[@]}")"
