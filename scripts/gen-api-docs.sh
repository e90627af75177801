#!/usr/bin/env bash
# Generates docs/api.md from the comments of the gRPC contract (proto/).
#   bash scripts/gen-api-docs.sh           rewrite docs/api.md
#   bash scripts/gen-api-docs.sh --check   exit 1 if docs/api.md is not what the .proto gives
# Needs protoc (protobuf-compiler) and Debian's python3-protobuf (/usr/bin/python3).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
check=0
case "${1:-}" in
  --check) check=1 ;;
  "") ;;
  *) echo "usage: gen-api-docs.sh [--check]" >&2; exit 2 ;;
esac

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$root/proto"
mapfile -t protos < <(find . -name '*.proto' -printf '%P\n' | LC_ALL=C sort)
[ "${#protos[@]}" -gt 0 ] || { echo "gen-api-docs: no .proto files under proto/" >&2; exit 1; }
protoc --include_source_info --include_imports --descriptor_set_out="$tmp/api.pb" -I . "${protos[@]}"
sources=()
for p in "${protos[@]}"; do sources+=(--source "$p"); done
/usr/bin/python3 -I -B "$root/scripts/gen_api_docs.py" --descriptor-set "$tmp/api.pb" \
  "${sources[@]}" --output "$tmp/api.md"

if [ "$check" -eq 1 ]; then
  if ! diff -u "$root/docs/api.md" "$tmp/api.md" >"$tmp/diff"; then
    head -40 "$tmp/diff"
    echo "docs/api.md is stale: run bash scripts/gen-api-docs.sh and commit it" >&2
    exit 1
  fi
  echo "docs/api.md is up to date"
else
  cp "$tmp/api.md" "$root/docs/api.md"
  echo "wrote docs/api.md"
fi
