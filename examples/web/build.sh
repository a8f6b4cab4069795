#!/usr/bin/env bash
# Builds examples/web the way a user of the installed package would: lockroll is configured for
# WebAssembly with emcmake (LOCKROLL_ENET=OFF: sim, rollback, the simulated network and the
# match), installed to OUT/prefix, and examples/web is built against that prefix with
# find_package(lockroll). The site (index.html, lockroll_web.js, lockroll_web.wasm) ends up in
# OUT/web/site; serve that directory over HTTP (a page cannot load WebAssembly from file://):
#
#   examples/web/build.sh out/web && python3 -m http.server --bind 127.0.0.1 -d out/web/web/site 8000
#
# Usage: examples/web/build.sh OUT [--jobs N]. Rebuilding into the same OUT is incremental.
# Exit status: 0 built; 2 bad usage; 3 emscripten (Debian package emscripten) or the xxHash /
# nlohmann-json headers are missing; 4 a build step failed.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
[[ $# -ge 1 ]] || { echo "usage: examples/web/build.sh OUT [--jobs N]" >&2; exit 2; }
out=$1
jobs=2
if [[ $# -ge 2 ]]; then
    [[ $# -eq 3 && $2 == --jobs && $3 =~ ^[1-9][0-9]*$ ]] || { echo "usage: examples/web/build.sh OUT [--jobs N]" >&2; exit 2; }
    jobs=$3
fi
for tool in emcmake em++ node; do
    command -v "$tool" >/dev/null || { echo "examples/web: '$tool' is missing (Debian packages emscripten, nodejs)" >&2; exit 3; }
done
for h in /usr/include/xxhash.h /usr/include/nlohmann/json.hpp; do
    [[ -e $h ]] || { echo "examples/web: missing $h (Debian packages libxxhash-dev, nlohmann-json3-dev)" >&2; exit 3; }
done
mkdir -p "$out"
out=$(cd "$out" && pwd)
# Debian's emscripten finds its node modules (acorn) there.
export NODE_PATH=/usr/share/nodejs${NODE_PATH:+:$NODE_PATH}
# Header-only dependencies through a directory of symlinks: emscripten must not see the host's
# /usr/include (its C library headers would shadow emscripten's).
mkdir -p "$out/include"
ln -sfn /usr/include/xxhash.h "$out/include/xxhash.h"
ln -sfn /usr/include/nlohmann "$out/include/nlohmann"

step() {  # step WHAT COMMAND...: runs it, its output in OUT/WHAT.log, shown only on failure
    local what=$1; shift
    if ! "$@" >"$out/$what.log" 2>&1; then
        cat "$out/$what.log" >&2
        echo "examples/web: $what failed (log: $out/$what.log)" >&2
        exit 4
    fi
}
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
step configure-lockroll emcmake cmake -S "$root" -B "$out/lockroll" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DLOCKROLL_ENET=OFF -DLOCKROLL_BUILD_TESTS=OFF -DLOCKROLL_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS=-fexceptions \
    -DXXHASH_INCLUDE_DIR="$out/include" -DNLOHMANN_JSON_INCLUDE_DIR="$out/include"
step build-lockroll cmake --build "$out/lockroll" -j "$jobs"
rm -rf "$out/prefix"
step install-lockroll cmake --install "$out/lockroll" --prefix "$out/prefix"
step configure-web emcmake cmake -S "$root/examples/web" -B "$out/web" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
    -Dlockroll_DIR="$out/prefix/lib/cmake/lockroll" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
step build-web cmake --build "$out/web" -j "$jobs"
echo "examples/web: built $out/web/site (index.html, lockroll_web.js, lockroll_web.wasm)"
