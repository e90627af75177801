#!/usr/bin/env bash
# deploy.scripts: the shell scripts of deploy/ parse, the maintainer scripts are executable and
# never reach the running system when dpkg installs into another root (DPKG_ROOT set), and
# wheeljump-profile refuses names that would leave /etc/wheeljump/profiles.
# usage: check_scripts.sh SOURCE_DIR
set -euo pipefail
src=$1
fail() { echo "FAIL: $*" >&2; exit 1; }
for f in "$src"/deploy/debian/*/* "$src"/deploy/wheeljump-profile; do
  sh -n "$f" || fail "$f does not parse"
  [ -x "$f" ] || fail "$f is not executable"
done
for f in "$src"/deploy/build-debs.sh "$src"/deploy/install-deps.sh "$src"/scripts/gen-api-docs.sh; do
  bash -n "$f" || fail "$f does not parse"
done
# Every systemctl call of a maintainer script sits behind the DPKG_ROOT guard.
for f in "$src"/deploy/debian/*/*; do
  if grep -q systemctl "$f"; then
    grep -q '\[ -z "\$DPKG_ROOT" \]' "$f" || fail "$f calls systemctl without checking DPKG_ROOT"
  fi
done
# Run every maintainer script against an empty scratch root with a systemctl that fails the
# test if called: nothing may happen outside DPKG_ROOT.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/bin" "$tmp/root/etc/wheeljump/profiles/nuc"
printf '#!/bin/sh\necho "systemctl called: $*" >&2\nexit 99\n' >"$tmp/bin/systemctl"
chmod +x "$tmp/bin/systemctl"
for f in "$src"/deploy/debian/*/*; do
  for action in configure remove purge upgrade; do
    PATH="$tmp/bin:$PATH" DPKG_ROOT="$tmp/root" sh "$f" "$action" "" >/dev/null 2>"$tmp/err" ||
      { cat "$tmp/err"; fail "$f $action failed"; }
    [ ! -s "$tmp/err" ] || { cat "$tmp/err"; fail "$f $action wrote to stderr"; }
  done
done
for bad in ../x . .. a/b; do
  if WHEELJUMP_ROOT="$tmp/root" sh "$src/deploy/wheeljump-profile" "$bad" 2>/dev/null; then
    fail "wheeljump-profile accepted '$bad'"
  fi
done
echo "scripts: ok"
