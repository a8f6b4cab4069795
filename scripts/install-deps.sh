#!/usr/bin/env bash
# Installs the Debian 12 packages lockroll needs, and only those missing. Safe to re-run; as
# root it uses apt-get directly, otherwise sudo. `--cross` adds the cross compilers, qemu-user,
# clang, emscripten and node used by scripts/cross-check.sh and examples/web, and the clang
# runtimes (ASan, UBSan, libFuzzer) used by scripts/sanitize.sh and scripts/fuzz.sh.
set -euo pipefail

packages=(g++ cmake ninja-build pkg-config
          libenet-dev libxxhash-dev libspdlog-dev libgtest-dev nlohmann-json3-dev libcli11-dev
          libbenchmark-dev python3 python3-matplotlib zlib1g-dev
          libsodium-dev  # the relay server's connect tokens (server/connect_token.h)
          libmimalloc-dev  # lockroll-server's allocator, optional (server/CMakeLists.txt)
          libbullet-dev  # the optional bench/bullet_bench comparison (docs/performance.md)
          chromium  # the headless browser test of lockroll view
          libsdl2-dev libsdl2-ttf-dev fonts-dejavu-core  # examples/room's window and overlay words
          xvfb xauth  # its window test under a virtual X server (tests/examples/room_test.sh)
          mono-mcs mono-runtime  # the C# P/Invoke sample over the C ABI (tests/capi)
          curl)     # the Agones sidecar script (server/agones) and its test
if [[ "${1:-}" == "--cross" ]]; then
  packages+=(clang libclang-rt-14-dev g++-aarch64-linux-gnu g++-s390x-linux-gnu g++-i686-linux-gnu
             g++-arm-linux-gnueabihf qemu-user emscripten nodejs)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

echo "installing: ${missing[*]}" >&2
sudo=""
[[ $(id -u) -eq 0 ]] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
