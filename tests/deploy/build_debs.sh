#!/usr/bin/env bash
# deploy.cpack: builds the Debian packages of this build folder into OUT (fixture wj_debs).
# usage: build_debs.sh BUILD_DIR OUT_DIR
set -euo pipefail
build=$1 out=$2
rm -rf "$out"
mkdir -p "$out"
cpack -G DEB --config "$build/CPackConfig.cmake" -B "$out" >"$out/cpack.log" 2>&1 || {
  cat "$out/cpack.log"
  exit 1
}
ls -l "$out"/*.deb
