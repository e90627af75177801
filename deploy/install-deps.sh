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
  # service tests: TLS certificates (openssl), the libFuzzer build (clang, libclang-rt-14-dev)
  openssl clang libclang-rt-14-dev
  # plots
  gnuplot-nox
  # shared cache of the planning service (docs/scaling.md): the Redis server the tests start,
  # its C client; python3-yaml for the checks of the Kubernetes manifests
  redis-server libhiredis-dev python3-yaml
  # Debian packages (cmake/Packaging.cmake): dpkg-shlibdeps for Depends, file for CPack's ELF
  # detection, systemd for `systemd-analyze verify` of the units in the deploy tests
  dpkg-dev file systemd
)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: done"
