#!/bin/sh
# agones-sidecar.sh: maps lockroll-server's status file onto the Agones SDK's REST API
# (docs/deployment.md). Runs as a second container of the GameServer pod, sharing the
# status file's directory (an emptyDir) with the server container:
#  - the file exists and says "ready"   -> POST /ready (once)
#  - the file was rewritten recently    -> POST /health (every period; a hung server stops
#                                          rewriting it, health stops, Agones marks it Unhealthy)
#  - the file says "draining", 0 rooms  -> POST /shutdown (the process drained and exits 0)
# Uses only POST /ready, /health and /shutdown of the SDK server on localhost.
set -u
status=${LOCKROLL_STATUS_FILE:-/run/lockroll/status.json}
sdk="http://localhost:${AGONES_SDK_HTTP_PORT:-9358}"
period=${LOCKROLL_HEALTH_PERIOD_S:-2}
stale=${LOCKROLL_STALE_S:-5}   # the server rewrites the file every second

post() { curl -s -f -m 2 -X POST -H 'Content-Type: application/json' -d '{}' "$sdk/$1" >/dev/null; }
field() { sed -n "s/.*\"$1\": \"\{0,1\}\([a-z0-9]*\).*/\1/p" "$status"; }

ready=0
while :; do
    if [ -f "$status" ]; then
        age=$(( $(date +%s) - $(stat -c %Y "$status") ))
        state=$(field state)
        rooms=$(field rooms)
        if [ "$age" -le "$stale" ]; then
            post health || echo "agones-sidecar: SDK not reachable yet" >&2
            if [ "$ready" = 0 ] && [ "$state" = ready ] && post ready; then
                ready=1
                echo "agones-sidecar: Ready" >&2
            fi
        fi
        if [ "$state" = draining ] && [ "$rooms" = 0 ]; then
            echo "agones-sidecar: drained; Shutdown" >&2
            post shutdown
            exit 0
        fi
    fi
    sleep "$period"
done
