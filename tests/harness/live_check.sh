# Shared by live_test.sh and live_faults_test.sh (sourced): tests/process_test_support.sh (tmp,
# fail, show_logs), and check, which runs Python assertions against one `lockroll live` run's
# live.json, summary and events, and shows the processes' logs when they fail.
source "$(dirname "${BASH_SOURCE[0]}")/../process_test_support.sh"

check() {  # check NAME DIR MODE PYTHON-ASSERTIONS (d: live.json's mode entry, procs by name)
    local name=$1 dir=$2 mode=$3 code=$4
    if /usr/bin/python3 - "$dir" "$mode" <<PY
import json, os, sys
d = json.load(open(os.path.join(sys.argv[1], "live.json")))["modes"][sys.argv[2]]
procs = {p["name"]: p for p in d["processes"]}
summary = json.load(open(os.path.join(sys.argv[1], sys.argv[2], "summary.json")))
def events(name):
    return [json.loads(l) for l in open(os.path.join(sys.argv[1], sys.argv[2], name, "events.jsonl"))]
$code
PY
    then echo "ok: $name"; else fail "$name"; show_logs "$dir"; fi
}
