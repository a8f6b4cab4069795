#!/usr/bin/env bash
# Checks server/Dockerfile where no Docker engine runs: each stage's RUN lines are executed, as
# written, in a Debian 12 root made by debootstrap (--variant=minbase, close to debian:12-slim),
# then the built lockroll-server runs in the runtime root as the image's unprivileged user:
# ready file, status file, a bad flag (exit 2), a SIGTERM drain (exit 0).
#
# By hand, as root, with network access to deb.debian.org (about 5 minutes and 700 MB in WORK):
#   bash server/check-image.sh [WORK]      (WORK defaults to a new directory under /tmp)
# What it does not check: the COPY/USER/ENTRYPOINT lines themselves (it mirrors them), and the
# build root starts from minbase rather than the full debian:12 image (a superset).
set -euo pipefail
cd "$(dirname "$0")/.."
[[ $(id -u) -eq 0 ]] || { echo "check-image: needs root (debootstrap, chroot)" >&2; exit 2; }
command -v debootstrap >/dev/null || { echo "check-image: apt-get install debootstrap" >&2; exit 2; }
work=${1:-$(mktemp -d /tmp/lockroll-image.XXXXXX)}
mkdir -p "$work"

# stage_runs STAGE_LINE: the RUN commands of the Dockerfile stage starting at STAGE_LINE, one per
# line, continuation backslashes joined.
stage_runs() {
    python3 - "$1" <<'PY'
import re, sys
s = open("server/Dockerfile").read()
start = s.index(sys.argv[1])
nxt = s.find("\nFROM ", start + 1)
stage = s[start: nxt if nxt >= 0 else len(s)]
for run in re.findall(r"^RUN (.*?)(?<!\\)\n", stage, re.S | re.M):
    print(run.replace("\\\n", " "))
PY
}

# root DIR: a fresh copy of a minbase Debian 12 root (bootstrapped once into WORK/base), with
# name resolution.
root() {
    [[ -x $work/base/bin/sh ]] || debootstrap --variant=minbase bookworm "$work/base" http://deb.debian.org/debian >"$work/debootstrap.log"
    rm -rf "$1" && cp -a "$work/base" "$1"
    cp /etc/resolv.conf "$1/etc/resolv.conf"
}

echo "check-image: build stage in $work/build-root"
root "$work/build-root"
mkdir -p "$work/build-root/src"
git archive HEAD | tar -x -C "$work/build-root/src"
{
    echo "set -e; export DEBIAN_FRONTEND=noninteractive"
    mapfile -t runs < <(stage_runs "FROM debian:12 AS build")
    echo "${runs[0]}"
    echo "cd /src"   # WORKDIR /src, COPY . .
    echo "${runs[1]}"
} >"$work/build-root/stage.sh"
chroot "$work/build-root" /bin/sh /stage.sh >"$work/build.log" 2>&1 || { tail -20 "$work/build.log"; echo "check-image: build stage FAILED"; exit 1; }

echo "check-image: runtime stage in $work/run-root"
root "$work/run-root"
{ echo "set -e; export DEBIAN_FRONTEND=noninteractive"; stage_runs "FROM debian:12-slim"; } >"$work/run-root/stage.sh"
chroot "$work/run-root" /bin/sh /stage.sh >"$work/run.log" 2>&1 || { tail -20 "$work/run.log"; echo "check-image: runtime stage FAILED"; exit 1; }
install -m755 "$work/build-root/build/server/lockroll-server" "$work/run-root/usr/local/bin/lockroll-server"
install -m755 server/agones/agones-sidecar.sh "$work/run-root/usr/local/bin/agones-sidecar.sh"

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
if chroot "$work/run-root" ldd /usr/local/bin/lockroll-server | grep -q "not found"; then fail "missing shared libraries"; fi
rm -f "$work/run-root/run/lockroll/"*
chroot --userspec=lockroll "$work/run-root" /usr/local/bin/lockroll-server --status-file /run/lockroll/status.json \
    --ready-file /run/lockroll/ready --listen 127.0.0.1:0 >"$work/server.log" 2>&1 &
pid=$!
for _ in $(seq 50); do [[ -s $work/run-root/run/lockroll/status.json ]] && break; sleep 0.1; done
[[ -s $work/run-root/run/lockroll/ready ]] || fail "no ready file"
grep -q '"state": "ready"' "$work/run-root/run/lockroll/status.json" 2>/dev/null || fail "no status file saying ready"
kill -TERM "$pid"
status=0
wait "$pid" || status=$?
[[ $status -eq 0 ]] || fail "SIGTERM drain exited $status"
status=0
chroot "$work/run-root" /usr/local/bin/lockroll-server --listen nonsense >/dev/null 2>&1 || status=$?
[[ $status -eq 2 ]] || fail "a bad flag exited $status, not 2"
[[ $failures -eq 0 ]] || exit 1
echo "check-image: both stages ran as written; the server runs as 'lockroll' with only the runtime packages"
