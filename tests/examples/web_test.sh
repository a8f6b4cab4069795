#!/usr/bin/env bash
# harness/web in a real browser (Debian's chromium, headless): the page, built for WebAssembly
# from the tree (harness/web/build.sh) and served on 127.0.0.1 only, runs a 600-frame match of the
# paper scene and must report, on both clients, the same confirmed checksum of the last frame as
# a native `lockroll run` with the same mode, seed and conditions, run here in the same test.
# Bad settings show lockroll's own message on the page. Screenshots are kept in OUT_DIR.
# Exit 77 (skipped) only when emscripten, node or chromium is not installed.
#
# Usage: web_test.sh LOCKROLL OUT_DIR (OUT_DIR/build is kept between runs: incremental).
set -u
lockroll=$1
out=$2
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
for need in "emcmake:emscripten" "em++:emscripten" "node:nodejs" "chromium:chromium"; do
    if ! command -v "${need%%:*}" >/dev/null; then
        echo "SKIP: '${need%%:*}' is not installed (Debian package '${need#*:}'; scripts/install-deps.sh installs it)"
        exit 77
    fi
done
mkdir -p "$out"
rm -rf "$out/native" "$out"/*.png
profile=$(mktemp -d)
server=""
cleanup() {
    [[ -n $server ]] && kill "$server" 2>/dev/null
    rm -rf "$profile"
}
trap cleanup EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

echo "building harness/web from the tree (first run: a few minutes)"
if ! timeout 1200 bash "$root/harness/web/build.sh" "$out/build"; then
    echo "FAIL: harness/web/build.sh"
    exit 1
fi
site=$out/build/web/site

# Serve the site on 127.0.0.1, on a port the system picks (printed by the server).
/usr/bin/python3 -u -m http.server 0 --bind 127.0.0.1 --directory "$site" >"$out/server.log" 2>&1 &
server=$!
port=""
for _ in $(seq 100); do
    port=$(sed -n 's/^Serving HTTP on 127\.0\.0\.1 port \([0-9]*\).*/\1/p' "$out/server.log")
    [[ -n $port ]] && break
    sleep 0.1
done
[[ -n $port ]] || { echo "FAIL: the HTTP server did not start: $(cat "$out/server.log")"; exit 1; }
echo "serving $site on 127.0.0.1:$port"

chrome() {  # chrome ARGS... : headless, no network services, bounded in time
    timeout 120 chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
        --disable-background-networking --disable-component-update --disable-sync \
        --user-data-dir="$profile" --virtual-time-budget=60000 "$@" 2>/dev/null
}

# check MODE LATENCY JITTER LOSS SEED: the page's final checksums equal the native run's.
check() {
    local mode=$1 latency=$2 jitter=$3 loss=$4 seed=$5 name="$1-seed$5" query dom
    "$lockroll" run --scene paper --mode "$mode" --frames 600 --latency "$latency" --jitter "$jitter" --loss "$loss" \
        --seed "$seed" --out "$out/native/$name" >/dev/null || { fail "$name: native lockroll run"; return; }
    query="mode=$mode&latency=$latency&jitter=$jitter&loss=$loss&seed=$seed&frames=600&fast=1"
    dom=$(chrome --dump-dom "http://127.0.0.1:$port/index.html?$query")
    /usr/bin/python3 - "$out/native/$name/summary.json" "$mode" <<PY || fail "$name: the page and lockroll run disagree"
import json, re, sys
dom = '''$(grep -o '<div id="result"[^>]*>' <<<"$dom")'''
page = dict(re.findall(r'data-(\w+)="([^"]*)"', dom))
native = json.load(open(sys.argv[1]))
finals = native["final_checksums"]
print("$name: page", page, "native final_checksums", finals)
assert page.get("done") == "1", "the page did not finish the match"
assert int(page["frames"]) >= 600, "fewer than 600 frames"
assert finals[0] is not None and finals[0] == finals[1], "native clients disagree"
assert page["checksum0"] == page["checksum1"] == finals[0], "checksums differ"
if sys.argv[2] == "rollback":
    assert int(page["rollbacks"]) > 0, "a rollback match with jitter and loss rolled back nowhere"
PY
    chrome --window-size=800,900 --screenshot="$out/$name.png" "http://127.0.0.1:$port/index.html?$query" >/dev/null
    [[ -s $out/$name.png ]] || fail "$name: no screenshot"
}
check rollback 28.5 10 0.05 7
check lockstep 28.5 10 0 1

# Bad settings: the page shows the match's own message and does not start.
dom=$(chrome --dump-dom "http://127.0.0.1:$port/index.html?loss=1&fast=1")
grep -q 'class="error">--loss must be below 1' <<<"$dom" || fail "loss=1: no error on the page"
grep -q 'data-done="1"' <<<"$dom" && fail "loss=1: a match ran"

echo "$failures failures"
[[ $failures -eq 0 ]]
