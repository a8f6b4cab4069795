#!/bin/sh
# agones-sidecar.sh: maps lockroll-server's status file onto the Agones SDK's REST API
# (docs/deployment.md). Runs as a second container of the GameServer pod, sharing the
# status file's directory (an emptyDir) with the server container:
#  - the file exists and says "ready"   -> POST /ready (once)
#  - the file was rewritten recently    -> POST /health (every period; a hung server stops
#                                          rewriting it, health stops, Agones marks it Unhealthy)
#  - rooms_closed grew by N             -> PATCH /v1beta1/counters/rooms {"countDiff": "-N"}
#                                          (gives the closed rooms back to the Counter that
#                                          each allocation incremented; retried until it takes)
#  - the file says "draining", 0 rooms  -> POST /shutdown (the process drained and exits 0)
# Uses only POST /ready, /health, /shutdown and PATCH /v1beta1/counters of the SDK server on
# localhost.
set -u
status=${LOCKROLL_STATUS_FILE:-/run/lockroll/status.json}
sdk="http://localhost:${AGONES_SDK_HTTP_PORT:-9358}"
period=${LOCKROLL_HEALTH_PERIOD_S:-2}
stale=${LOCKROLL_STALE_S:-5}   # the server rewrites the file every second

counter=${LOCKROLL_ROOMS_COUNTER:-rooms}

post() { curl -s -f -m 2 -X POST -H 'Content-Type: application/json' -d '{}' "$sdk/$1" >/dev/null; }
# The Counter's count goes down by $1 (Agones refuses a count below 0 or above capacity).
decrement() {
    curl -s -f -m 2 -X PATCH -H 'Content-Type: application/json' -d "{\"countDiff\": \"-$1\"}" \
        "$sdk/v1beta1/counters/$counter" >/dev/null
}
field() { sed -n "s/.*\"$1\": \"\{0,1\}\([a-z0-9]*\).*/\1/p" "$status"; }

ready=0
given_back=   # rooms_closed already given back to the Counter (unset until the first read)
while :; do
    if [ -f "$status" ]; then
        age=$(( $(date +%s) - $(stat -c %Y "$status") ))
        state=$(field state)
        rooms=$(field rooms)
        closed=$(field rooms_closed)
        # Rooms closed before the sidecar first looked were never seen open by it: start there.
        [ -z "$given_back" ] && given_back=${closed:-0}
        if [ -n "$closed" ] && [ "$closed" -gt "$given_back" ]; then
            if decrement $((closed - given_back)); then
                echo "agones-sidecar: gave $((closed - given_back)) closed room(s) back to the $counter Counter" >&2
                given_back=$closed
            else
                echo "agones-sidecar: Counter update failed; retrying" >&2
            fi
        fi
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
