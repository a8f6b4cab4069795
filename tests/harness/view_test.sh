#!/usr/bin/env bash
# lockroll view in a real browser (Debian's chromium, headless, driven directly): the page loads
# from a file with no network, scrubs to a frame with a known error (from the URL hash) and
# reports for it exactly what frames.csv says; a large run's data is gzipped and still loads.
# The error plot has round time ticks inside the run. A screenshot is kept in OUT_DIR. Exit 77 (skipped) only when chromium is not installed.
set -u
lockroll=$1
out=${2:-$(mktemp -d)}
browser=$(command -v chromium || true)
if [[ -z $browser ]]; then
    echo "SKIP: chromium is not installed (Debian package 'chromium'; scripts/install-deps.sh installs it)"
    exit 77
fi
rm -rf "$out"
mkdir -p "$out"
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

chrome() {  # chrome ARGS... : headless, no network services, bounded in time
    timeout 90 "$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
        --disable-background-networking --disable-component-update --disable-sync \
        --user-data-dir="$profile" --virtual-time-budget=5000 "$@" 2>/dev/null
}

# check_frame DIR FRAME: the page's reported error for FRAME equals DIR/frames.csv's row.
check_frame() {
    local dir=$1 frame=$2 dom
    dom=$(chrome --dump-dom "file://$dir/view.html#frame=$frame")
    /usr/bin/python3 - "$dir/frames.csv" "$frame" <<PY || fail "$dir: page and frames.csv disagree on frame $frame"
import csv, re, sys
dom = '''$(grep -o '<div id="frame-error"[^>]*>' <<<"$dom")'''
attrs = dict(re.findall(r'data-(\w+)="([^"]*)"', dom))
row = next(r for r in csv.DictReader(open(sys.argv[1])) if r["frame"] == sys.argv[2])
print("page:", attrs, "frames.csv:", {k: row[k] for k in ("frame", "mean_error", "max_error")})
assert attrs.get("frame") == row["frame"], "frame"
assert float(attrs["mean"]) == float(row["mean_error"]), "mean"
assert float(attrs["max"]) == float(row["max_error"]), "max"
PY
    # The plot's time axis: at least 5 round ticks, increasing, inside the run's time range.
    /usr/bin/python3 - "$dir/frames.csv" <<PY || fail "$dir: the error plot's time ticks"
import csv, re, sys
dom = '''$(grep -o '<div id="plot-axes"[^>]*>' <<<"$dom")'''
attrs = dict(re.findall(r'data-(\w+)="([^"]*)"', dom))
times = [float(r["time_s"]) for r in csv.DictReader(open(sys.argv[1]))]
ticks = [float(t) for t in attrs.get("xticks", "").split(",") if t]
print("time ticks:", ticks, "run time:", min(times), "..", max(times), "error ticks:", attrs.get("yticks"))
assert len(ticks) >= 5, "fewer than 5 time ticks"
assert ticks == sorted(ticks) and len(set(ticks)) == len(ticks), "ticks not increasing"
assert min(times) - 1e-9 <= ticks[0] and ticks[-1] <= max(times) + 1e-9, "a tick outside the run"
assert attrs.get("yticks"), "no error ticks"
PY
}

# A rollback run at input delay 0 has frames with error; scrub to the worst one.
"$lockroll" run --scene paper --frames 180 --latency 28.5 --jitter 10 --input-delay 0 --view --out "$out/run" >/dev/null ||
    fail "lockroll run --view"
[[ -f $out/run/view.html ]] || fail "no view.html"
frame=$(awk -F, 'NR > 1 && $3 + 0 > best { best = $3 + 0; f = $1 } END { print f }' "$out/run/frames.csv")
[[ -n $frame ]] || fail "no frame with error to scrub to"
echo "scrubbing to frame $frame"
check_frame "$out/run" "$frame"
chrome --window-size=1100,1000 --screenshot="$out/view-frame-$frame.png" "file://$out/run/view.html#frame=$frame" >/dev/null
[[ -s $out/view-frame-$frame.png ]] && echo "screenshot: $out/view-frame-$frame.png" || fail "no screenshot"
# Self-contained: nothing fetched from anywhere.
if grep -qE '(src|href)=|https?://' "$out/run/view.html"; then fail "view.html refers to outside resources"; fi

# A large run (1k bodies): the data is compressed and the page still reports frames.csv's values.
"$lockroll" run --scene bodies_1k --frames 40 --latency 28.5 --jitter 10 --input-delay 0 --out "$out/big" --positions >/dev/null ||
    fail "lockroll run bodies_1k"
"$lockroll" view "$out/big" >/dev/null || fail "lockroll view"
grep -q 'data-encoding="gzip+base64"' "$out/big/view.html" || fail "large data not compressed"
frame=$(awk -F, 'NR > 1 && $3 + 0 >= best { best = $3 + 0; f = $1 } END { print f }' "$out/big/frames.csv")
check_frame "$out/big" "$frame"

# Real processes: lockroll live --view writes each mode's page from the processes' shown
# positions, and it reports what the mode's frames.csv says.
"$lockroll" live --players 2 --frames 180 --latency 28.5 --jitter 10 --mode rollback --no-virtual --view \
    --out "$out/live" >/dev/null 2>&1 || fail "lockroll live --view"
[[ -f $out/live/rollback/view.html ]] || fail "live: no view.html"
frame=$(awk -F, 'NR > 1 && $3 + 0 >= best { best = $3 + 0; f = $1 } END { print f }' "$out/live/rollback/frames.csv")
[[ -n $frame ]] && check_frame "$out/live/rollback" "$frame"

# Bad input: exit 2 naming the file, nothing written.
mkdir -p "$out/empty"
msg=$("$lockroll" view "$out/empty" 2>&1)
[[ $? -eq 2 && $msg == *frames.csv* && ! -e $out/empty/view.html ]] || fail "view of an empty directory: $msg"

echo "$failures failures"
[[ $failures -eq 0 ]]
