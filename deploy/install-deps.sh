#!/usr/bin/env bash
# Installs every build, test and runtime dependency of the project from Debian 12 packages.
# Idempotent: packages already present are skipped by apt; safe to run on every CI run.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang-format
  # RPC and contract
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  python3-grpcio python3-protobuf
  # maths, optimisation, simulation
  libeigen3-dev coinor-libipopt-dev libsimbody-dev libpagmo-dev
  # robot description, configuration, logging, command line
  liburdfdom-dev libyaml-cpp-dev libspdlog-dev libcli11-dev nlohmann-json3-dev
  # hardware
  libsocketcan-dev can-utils iproute2
  # persistence
  libsqlite3-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # the shell scripts' lint (tests/deploy/check_shellcheck.sh)
  shellcheck
  # service tests: TLS certificates (openssl), the libFuzzer build (clang, libclang-rt-14-dev)
  openssl clang libclang-rt-14-dev
  # plots
  gnuplot-nox
  # the 3D replay pages' browser test (tests/viz): Debian's chromium, headless
  chromium
  # shared cache of the planning service (docs/scaling.md): the Redis server the tests start,
  # its C client; python3-yaml for the checks of the Kubernetes manifests
  redis-server libhiredis-dev python3-yaml
  # Debian packages (cmake/Packaging.cmake): dpkg-shlibdeps for Depends, file for CPack's ELF
  # detection, systemd for `systemd-analyze verify` of the units in the deploy tests
  dpkg-dev file systemd
)

# Node.js and npm for the viewer's JavaScript packages (viz/web): Debian's, unless a node with
# npm is already there (a nodesource node bundles npm and conflicts with Debian's npm package).
if ! command -v npm >/dev/null 2>&1; then PACKAGES+=(nodejs npm); fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

# three.js (inlined into the replay pages) and playwright-core (drives chromium in the browser
# test), pinned by viz/web/package-lock.json. No browser is downloaded: the test uses Debian's.
# Skipped when node_modules already holds exactly this lock file.
install_npm_packages() {
  local web
  web="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/viz/web"
  if [ ! -f "$web/package.json" ]; then  # the script alone (the container's first stage)
    echo "install-deps: no viz/web beside this script, npm packages skipped"
    return
  fi
  if cmp -s "$web/package-lock.json" "$web/node_modules/.wj-package-lock.json"; then
    echo "install-deps: npm packages of viz/web present"
    return
  fi
  echo "install-deps: npm ci in viz/web"
  (cd "$web" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --ignore-scripts --no-audit --no-fund)
  cp "$web/package-lock.json" "$web/node_modules/.wj-package-lock.json"
}

missing=()
for p in "${PACKAGES[@]}"; do
  # The status is read whole before it is compared: `producer | grep -q` under pipefail fails
  # when grep exits before the producer has written everything (SIGPIPE, issue 26).
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  if [ "$status" != "install ok installed" ]; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  install_npm_packages
  exit 0
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
install_npm_packages
echo "install-deps: done"
