#!/usr/bin/env bash
# Installs the dependencies, builds the release preset and runs every test under ctest.
# This is the README's test command and what CI runs.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
cmake --preset release
cmake --build --preset release
ctest --preset release "$@"
