#!/usr/bin/env bash
# Builds the Debian packages of wheeljump on this machine (Debian 12):
#   bash deploy/build-debs.sh            -> build/debs/wheeljump-*.deb
# then install them with
#   sudo apt install ./build/debs/*.deb
# It installs the build dependencies (deploy/install-deps.sh), configures an optimised build
# without tests in build/deb, builds the packaged binaries only, and runs CPack (DEB).
# Environment: BUILD_DIR (default build/deb), OUT_DIR (default build/debs), JOBS (default: all
# cores), WJ_COMPONENTS (default: all, "planner;sim;server;robot_client").
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
build=${BUILD_DIR:-build/deb}
out=${OUT_DIR:-build/debs}
jobs=${JOBS:-$(nproc)}
components=${WJ_COMPONENTS:-planner;sim;server;robot_client}

bash deploy/install-deps.sh
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_INSTALL_PREFIX=/usr \
  -DWJ_BUILD_TESTS=OFF -DWJ_BUILD_BENCHMARKS=OFF -DWJ_COMPONENTS="$components"
targets=(planner_server planner_cli)
if ninja -C "$build" -t targets all | grep -q '^robot_client:'; then targets+=(robot_client); fi
cmake --build "$build" -j "$jobs" --target "${targets[@]}"
rm -rf "$out"
mkdir -p "$out"
cpack -G DEB --config "$build/CPackConfig.cmake" -B "$out"
rm -rf "$out/_CPack_Packages"
echo
echo "packages:"
ls -1 "$out"/*.deb
case "$out" in /*) prefix="" ;; *) prefix="./" ;; esac
echo "install them with: sudo apt install $(printf "$prefix%s " "$out"/*.deb)"
