#!/usr/bin/env bash
# Soak (label soak, run by hand; figures in docs/performance.md): `lockroll live` at the seed
# paper's conditions -- 2 players, 28.5 ms one way +-10 ms through `lockroll proxy`, both modes,
# 720 frames. Lockstep must hold >= 59 ticks/s with zero positional error, rollback ~60 ticks/s,
# both with equal final checksums. Timing-dependent, hence not in the default run.
set -u
lockroll=$1
out=${2:-$(mktemp -d)}
"$lockroll" live --players 2 --frames 720 --latency 28.5 --jitter 10 --mode both --out "$out" || exit 1
/usr/bin/python3 - "$out" <<'PY'
import json, os, sys
d = sys.argv[1]
live = json.load(open(os.path.join(d, "live.json")))
assert live["ok"], live
ls = json.load(open(os.path.join(d, "lockstep", "summary.json")))
rb = json.load(open(os.path.join(d, "rollback", "summary.json")))
print(f"lockstep {ls['ticks_per_second']:.2f} ticks/s error {ls['position_error']['max']}; "
      f"rollback {rb['ticks_per_second']:.2f} ticks/s mean error {rb['position_error']['mean']:.3g}")
assert ls["ticks_per_second"] >= 59 and ls["position_error"]["max"] == 0, ls["ticks_per_second"]
assert rb["ticks_per_second"] >= 59.5, rb["ticks_per_second"]
assert ls["confirmed_mismatches"] == 0 and rb["confirmed_mismatches"] == 0
PY
