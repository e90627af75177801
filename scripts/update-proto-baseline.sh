#!/usr/bin/env bash
# Regenerates the committed baseline of the gRPC contract (proto/baseline/), against which
# the contract tests reject breaking changes (tests/contract/README.md).
#
# Run it only on purpose: after a deliberate, reviewed break of the contract (a version bump),
# or after compatible additions that should become the new reference. Then commit the new
# baseline together with the proto change, saying why in the commit message.
#
# The baseline is produced exactly as proto/CMakeLists.txt produces the build's descriptor
# set (same protoc, same options), so right after this script the two are byte-identical.
set -euo pipefail
cd "$(dirname "$0")/../proto"

PROTOC="${PROTOC:-/usr/bin/protoc}"
BASELINE=baseline/wheeljump_planner_v1.binpb

mapfile -t protos < <(find wheeljump -name '*.proto' | LC_ALL=C sort)
if [ "${#protos[@]}" -eq 0 ]; then
  echo "update-proto-baseline: no .proto files under proto/wheeljump" >&2
  exit 1
fi

mkdir -p baseline
"$PROTOC" --proto_path=. --include_source_info --descriptor_set_out="$BASELINE" "${protos[@]}"

echo "update-proto-baseline: wrote proto/$BASELINE from ${protos[*]} ($("$PROTOC" --version))"
if ! git ls-files --error-unmatch "$BASELINE" >/dev/null 2>&1; then
  echo "update-proto-baseline: new baseline; commit it"
elif git diff --quiet -- "$BASELINE"; then
  echo "update-proto-baseline: baseline unchanged"
else
  echo "update-proto-baseline: baseline changed; review, then commit it with the proto change"
fi
