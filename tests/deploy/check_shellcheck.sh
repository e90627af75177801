#!/usr/bin/env bash
# deploy.shellcheck: Debian's shellcheck, warning level, over every shell script of the
# repository: *.sh, .ci/run, the maintainer scripts and wheeljump-profile.
# usage: check_shellcheck.sh SOURCE_DIR
set -euo pipefail
src=$1
command -v shellcheck >/dev/null || { echo "FAIL: shellcheck is not installed (deploy/install-deps.sh installs it)" >&2; exit 1; }
cd "$src"
mapfile -t scripts < <(find . \( -path ./build -o -path ./.git -o -name node_modules \) -prune -o \
  -type f \( -name '*.sh' -o -path ./.ci/run -o -path './deploy/debian/*' \
  -o -path ./deploy/wheeljump-profile \) -print | sort)
[ "${#scripts[@]}" -ge 20 ] || { echo "FAIL: found only ${#scripts[@]} scripts" >&2; exit 1; }
shellcheck -S warning -x "${scripts[@]}"
echo "shellcheck: ${#scripts[@]} scripts clean at warning level"
