#!/usr/bin/env bash
# Builds harness/web from the tree: lockroll is configured for WebAssembly with emcmake
# (LOCKROLL_ENET=OFF: sim, rollback, the simulated network, the match and, under emscripten, this
# page) in OUT/lockroll and its target lockroll_web built. The site (index.html, lockroll_web.js,
# lockroll_web.wasm) is copied to OUT/web/site; serve that directory over HTTP (a page cannot
# load WebAssembly from file://):
#
#   harness/web/build.sh out/web && python3 -m http.server --bind 127.0.0.1 -d out/web/web/site 8000
#
# Usage: harness/web/build.sh OUT [--jobs N]. Rebuilding into the same OUT is incremental.
# Exit status: 0 built; 2 bad usage; 3 emscripten (Debian package emscripten) or the xxHash /
# nlohmann-json headers are missing; 4 a build step failed.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
[[ $# -ge 1 ]] || { echo "usage: harness/web/build.sh OUT [--jobs N]" >&2; exit 2; }
out=$1
jobs=2
if [[ $# -ge 2 ]]; then
    [[ $# -eq 3 && $2 == --jobs && $3 =~ ^[1-9][0-9]*$ ]] || { echo "usage: harness/web/build.sh OUT [--jobs N]" >&2; exit 2; }
    jobs=$3
fi
for tool in emcmake em++ node; do
    command -v "$tool" >/dev/null || { echo "harness/web: '$tool' is missing (Debian packages emscripten, nodejs)" >&2; exit 3; }
done
for h in /usr/include/xxhash.h /usr/include/nlohmann/json.hpp; do
    [[ -e $h ]] || { echo "harness/web: missing $h (Debian packages libxxhash-dev, nlohmann-json3-dev)" >&2; exit 3; }
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
        echo "harness/web: $what failed (log: $out/$what.log)" >&2
        exit 4
    fi
}
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
step configure-lockroll emcmake cmake -S "$root" -B "$out/lockroll" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DLOCKROLL_ENET=OFF -DLOCKROLL_BUILD_TESTS=OFF -DLOCKROLL_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS=-fexceptions \
    -DXXHASH_INCLUDE_DIR="$out/include" -DNLOHMANN_JSON_INCLUDE_DIR="$out/include"
step build-web cmake --build "$out/lockroll" -j "$jobs" --target lockroll_web
rm -rf "$out/web/site"
mkdir -p "$out/web"
cp -r "$out/lockroll/harness/web/site" "$out/web/site"
echo "harness/web: built $out/web/site (index.html, lockroll_web.js, lockroll_web.wasm)"
