#!/usr/bin/env bash
# deploy.build_debs_script: deploy/build-debs.sh builds CMake's wj_packaged target, fails when
# CPack drops (or adds) a package against the build's wj_deb_packages.txt, and refuses bad
# options by name. cmake, cpack and ninja are fakes on PATH, so this takes no build.
# usage: check_build_debs.sh SOURCE_DIR
set -euo pipefail
src=$1
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/bin" "$tmp/build"
# cmake: records its arguments. cpack: makes the packages named in FAKE_CPACK_MAKES in its -B
# folder. ninja: must not be called (its target listing raced grep -q under pipefail, #26).
cat >"$tmp/bin/cmake" <<'SH'
#!/usr/bin/env bash
echo "cmake $*" >>"$FAKE_LOG"
SH
cat >"$tmp/bin/cpack" <<'SH'
#!/usr/bin/env bash
while [ $# -gt 0 ]; do [ "$1" = -B ] && out=$2; shift; done
for name in $FAKE_CPACK_MAKES; do touch "$out/${name}_0.1.0_amd64.deb"; done
SH
printf '#!/bin/sh\necho "ninja called: $*" >&2\nexit 99\n' >"$tmp/bin/ninja"
chmod +x "$tmp/bin/"*
printf 'wheeljump-common\nwheeljump-planner-server\nwheeljump-robot-client\n' \
  >"$tmp/build/wj_deb_packages.txt"
export FAKE_LOG="$tmp/log"
run() { # run ARGS...: the script against the fake build; output in $tmp/out.txt, status returned
  PATH="$tmp/bin:$PATH" bash "$src/deploy/build-debs.sh" --no-deps --configured \
    --build-dir "$tmp/build" --out-dir "$tmp/debs" "$@" >"$tmp/out.txt" 2>&1
}
all="wheeljump-common wheeljump-planner-server wheeljump-robot-client"

FAKE_CPACK_MAKES=$all run --jobs 2 || { cat "$tmp/out.txt"; fail "all packages made, yet it failed"; }
grep -q -- "--target wj_packaged" "$FAKE_LOG" || fail "it did not build the wj_packaged target"
for name in $all; do
  grep -q "$name" "$tmp/out.txt" || fail "the package list does not show $name"
done

FAKE_CPACK_MAKES="wheeljump-common wheeljump-planner-server" run &&
  fail "CPack dropped wheeljump-robot-client, yet it succeeded"
grep -q "wheeljump-robot-client" "$tmp/out.txt" || fail "the error does not name the dropped package"

FAKE_CPACK_MAKES="$all wheeljump-stray" run && fail "an undeclared package was accepted"
grep -q "declares 3" "$tmp/out.txt" || fail "the error does not give the declared count"

export FAKE_CPACK_MAKES=$all
for bad in "--jobs 0" "--jobs x" "--frobnicate" "--out-dir"; do
  # shellcheck disable=SC2086 # the option and its value are two words on purpose
  run $bad && fail "accepted '$bad'"
  grep -q -- "${bad%% *}" "$tmp/out.txt" || fail "the error for '$bad' does not name the option"
done
rm "$tmp/build/wj_deb_packages.txt"
run && fail "--configured accepted a folder that is not a configured build"
grep -q "wj_deb_packages.txt" "$tmp/out.txt" || fail "the --configured error does not say why"
echo "build-debs.sh: ok"
