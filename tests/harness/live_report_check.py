#!/usr/bin/env python3
"""Recomputes every row of a `lockroll live` report (report.md) from the raw files its processes
wrote (each process's samples.json, positions.csv and summary.json; live.json for who was
killed) and compares: a number the report shows must be the one the raw data gives, and "n/a"
must stand exactly where the raw data has no sample. Independent of the C++ code that made the
report: it reads only the files.

    live_report_check.py RUN_DIR MODE                  check RUN_DIR/report.md; exit 1 on a mismatch
    live_report_check.py RUN_DIR MODE REPORT           check another report file (a doctored one)
    live_report_check.py RUN_DIR MODE REPORT COLUMN    the run's column of a several-run table
                                                       (compare's: 1 lockstep, 2 rollback, 3 rollback-delay0)

Exit 1 also when a file it recomputes from is missing (a run where no process played has no
bodies.csv and no samples.json): one line, "CANNOT CHECK", naming the file and the directory,
and no traceback. A report cannot be shown to match data that is not there.
"""
import json
import math
import os
import re
import sys


def percentile(values, p):
    if not values:
        return 0.0
    s = sorted(values)
    k = max(0, math.ceil(p / 100.0 * len(s)) - 1)
    return s[min(k, len(s) - 1)]


def mean(values):
    return sum(values) / len(values) if values else 0.0


def tick_figures(shown, tick_rate):
    """(ticks/s, stall fraction) from [(frame, us)], as a frame late by more than a period is a stall."""
    if len(shown) < 2:
        return 0.0, 0.0
    period = 1e6 / tick_rate
    stalled = 0
    for (_, a), (_, b) in zip(shown, shown[1:]):
        stalled += max(0, math.floor((b - a - period) / period + 1e-6))
    intervals = shown[-1][0] - shown[0][0]
    seconds = (shown[-1][1] - shown[0][1]) / 1e6
    rate = intervals / seconds if seconds > 0 else 0.0
    return rate, (stalled / (stalled + intervals) if stalled + intervals else 0.0)


class Missing(Exception):
    """A file the report is checked against is not there: nothing to recompute from."""


def need(path, why=""):
    """path, if it exists; else Missing naming the file, where it should be, and why it may not be."""
    if not os.path.exists(path):
        raise Missing("%s is missing%s" % (path, why))
    return path


def read_csv(path):
    with open(path) as f:
        lines = f.read().splitlines()
    return [l.split(",") for l in lines[1:] if l]


class Process:
    def __init__(self, mode_dir, entry):
        self.name = entry["name"]
        self.role = entry["role"]
        self.slot = entry["slot"]
        d = os.path.join(mode_dir, self.name)
        self.summary = json.load(open(need(os.path.join(d, "summary.json"))))
        self.samples = json.load(open(need(os.path.join(d, "samples.json"))))
        self.positions = {}
        for row in read_csv(need(os.path.join(d, "positions.csv"))):
            self.positions.setdefault(int(row[0]), []).append((int(row[6]), int(row[7]), int(row[8])))


def recompute(run_dir, mode):
    """Every row of the report's figures table: row name -> the cell the raw data gives."""
    mode_dir = os.path.join(run_dir, mode)
    modes = json.load(open(need(os.path.join(run_dir, "live.json"))))["modes"]
    if mode not in modes:
        raise Missing("no mode %r in %s (it has: %s)" % (mode, os.path.join(run_dir, "live.json"), ", ".join(modes)))
    live = modes[mode]
    mode_summary = json.load(open(need(os.path.join(mode_dir, "summary.json"))))
    frames, tick_rate = mode_summary["frames"], mode_summary["tick_rate"]
    n_players = mode_summary["players"]
    procs = [Process(mode_dir, e) for e in live["processes"]
             if e["outcome"] != "killed" and os.path.exists(os.path.join(mode_dir, e["name"], "samples.json"))]
    players = [p for p in procs if p.role != "spectator"]
    # live writes bodies.csv only when some process showed positions, and the figures below need
    # at least one player's samples: a run in which no process played has neither.
    outcomes = ", ".join("%s %s" % (e["name"], e["outcome"]) for e in live["processes"])
    if not players:
        bodies_csv = os.path.join(mode_dir, "bodies.csv")
        raise Missing("no player played in %s: no player's samples.json there%s (%s)" % (
            mode_dir, "" if os.path.exists(bodies_csv) else ", and %s is missing" % bodies_csv, outcomes))
    bodies = read_csv(need(os.path.join(mode_dir, "bodies.csv"), " (processes: %s)" % outcomes))
    body_player = {int(b[0]): int(b[2]) for b in bodies if b[3] == "1"}
    n_bodies = len(body_player)
    rows = {}
    na = "n/a"

    figs = {p.name: tick_figures([tuple(x) for x in p.samples["shown_us"]], tick_rate) for p in players}
    from_start = [p for p in players if p.role == "player"] or players
    rows["ticks per second"] = "%.2f" % mean([figs[p.name][0] for p in from_start])
    rows["stall fraction"] = "%.3f" % mean([figs[p.name][1] for p in from_start])
    rows["input delay (frames)"] = str(mode_summary["input_delay_frames"])

    def spread(v):
        return na if not v else "%.1f / %.1f / %.1f / %.1f" % (percentile(v, 50), percentile(v, 95), percentile(v, 99), max(v))

    local = [x for p in players for x in p.samples["input_latency_local_ms"]]
    remote = []
    for maker in players:
        for frame, made_bytes, t in maker.samples["inputs_made"]:
            for other in players:
                if other is maker or other.slot == maker.slot:
                    continue
                for slot, f, seen_bytes, ts in other.samples["inputs_seen"]:
                    if slot == maker.slot and f == frame and seen_bytes == made_bytes and ts >= t:
                        remote.append((ts - t) / 1000.0)
                        break
    rows["input latency, local (ms)"] = "%.1f" % mean(local) if local else na
    rows["input latency, remote (ms)"] = "%.1f" % mean(remote) if remote else na
    rows["local p50 / p95 / p99 / max (ms)"] = spread(local)
    rows["remote p50 / p95 / p99 / max (ms)"] = spread(remote)
    rtt = [v for p in players for v in p.samples["rtt_ms"].values() if v]
    rows["RTT p50 / p99, worst peer (ms)"] = (
        "%.1f / %.1f" % (max(percentile(v, 50) for v in rtt), max(percentile(v, 99) for v in rtt)) if rtt else na)

    # Position error: every frame, every pair of slots that both showed it, every body.
    shown = [dict() for _ in range(n_players)]
    for p in players:
        for f, v in p.positions.items():
            if len(v) == n_bodies and 1 <= f <= frames:
                shown[p.slot].setdefault(f, v)
    errors, on_players = [], 0
    for f in range(1, frames + 1):
        for a in range(n_players):
            for b in range(a + 1, n_players):
                if f not in shown[a] or f not in shown[b]:
                    continue
                for k, (pa, pb) in enumerate(zip(shown[a][f], shown[b][f])):
                    e = math.sqrt(sum(((x - y) / 4294967296.0) ** 2 for x, y in zip(pa, pb)))
                    errors.append(e)
                    if e != 0 and body_player.get(k, -1) >= 0:
                        on_players += 1
    nonzero = sum(1 for e in errors if e != 0)
    rows["mean positional error (m)"] = "%.3g" % mean(errors) if errors else na
    rows["max positional error (m)"] = "%.3g" % max(errors) if errors else na
    rows["non-zero error samples"] = "%d / %d" % (nonzero, len(errors)) if errors else na
    rows["non-zero samples on player bodies"] = "%d of %d" % (on_players, nonzero) if errors else na
    dvc = [p.samples["displayed_vs_confirmed_m"] for p in players]
    count = sum(d["count"] for d in dvc)
    rows["shown vs confirmed state, mean / max (m)"] = (
        "%.3g / %.3g" % (sum(d["sum"] for d in dvc) / count, max(d["max"] for d in dvc)) if count else na)

    first, compared, mismatches = {}, 0, 0
    for p in procs:  # every process that confirmed frames, spectators too
        for f, c in p.samples["confirmed_checksums"]:
            if f in first:
                compared += 1
                mismatches += first[f] != c
            else:
                first[f] = c
    rows["confirmed-state mismatches (of checksums compared)"] = "%d of %d" % (mismatches, compared) if compared else na

    depths = [d for p in players for d in p.samples["rollback_depths"]]
    rows["rollbacks (mean / max depth)"] = "%d (%.2f / %.0f)" % (len(depths), mean(depths), max(depths)) if depths else "0"
    jumps = [j for p in players for j in p.samples["correction_jumps_m"]]
    rows["visual corrections (max jump m)"] = "%d (%.3g)" % (len(jumps), max(jumps)) if jumps else "0"
    cpu = [x for p in players for x in p.samples["cpu_us_per_tick"]]
    rows["CPU per tick, mean / p99 (µs)"] = "%.1f / %.1f" % (mean(cpu), percentile(cpu, 99)) if cpu else na
    rows["worst / p99 tick vs budget (µs)"] = (
        "%.0f / %.0f of %.0f" % (max(cpu), percentile(cpu, 99), 1e6 / tick_rate) if cpu else na)
    seconds = max(p.summary["wall_seconds"] for p in procs)
    clients = [p.summary["clients"][0] for p in players]
    resim_frames = sum(c["resimulated_frames"] for c in clients)
    rows["resimulated frames per second"] = "%.1f" % (resim_frames / len(clients) / seconds)
    physics = [x for p in players for x in p.samples["physics_step_us"]]
    window = mode_summary["prediction_window"]
    resim_us = sum(x for p in players for x in p.samples["resim_us_per_tick"])
    per_frame = resim_us / resim_frames if resim_frames else percentile(physics, 50)
    rows["full-window rollback, projected (µs)"] = (
        "—" if not window else na if not resim_frames and not physics else "%.0f (W=%d)" % (window * per_frame, window))
    rows["physics step, median CPU (µs)"] = "%.2f" % percentile(physics, 50) if physics else na
    sent = sum(c["bytes_sent"] for c in clients) / len(clients) / seconds
    packets = sum(c["packets_sent"] for c in clients) / len(clients) / seconds
    rows["payload sent per client (B/s)"] = "%.0f" % sent
    rows["with UDP/IPv4 headers (B/s)"] = "%.0f" % (sent + packets * 28)
    rows["desyncs"] = str(sum(c["desyncs"] for c in clients))
    return rows


def report_rows(text, column=1):
    """The figures table of report.md: row name -> the cell of run `column` (1: the first)."""
    rows = {}
    for line in text.splitlines():
        if not line.startswith("| ") or line.startswith("| |") or line.startswith("|---"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) > column and cells[0] not in rows:
            rows[cells[0]] = cells[column]
    return rows


NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def same_cell(shown, expected):
    """Equal text around the numbers, and each number equal to within the shown precision."""
    shown = re.sub(r"n/a \[\d+\]", "n/a", shown)
    if NUMBER.sub("#", shown) != NUMBER.sub("#", expected):
        return False
    for a, b in zip(NUMBER.findall(shown), NUMBER.findall(expected)):
        x, y = float(a), float(b)
        mantissa = a.split("e")[0]
        unit = 10.0 ** -(len(mantissa.split(".")[1]) if "." in mantissa else 0)
        if "e" in a:
            unit *= 10.0 ** int(a.split("e")[1])
        if abs(x - y) > 1.01 * unit + 1e-3 * abs(y):
            return False
    return True


def check(report_text, expected, column=1):
    """Mismatches, one line each: rows the report shows differently, or leaves out."""
    shown = report_rows(report_text, column)
    bad = []
    for name, want in expected.items():
        if name not in shown:
            bad.append("%s: missing from the report" % name)
        elif not same_cell(shown[name], want):
            bad.append("%s: report %r, raw data %r" % (name, shown[name], want))
    return bad


def main():
    run_dir, mode = sys.argv[1], sys.argv[2]
    report = sys.argv[3] if len(sys.argv) > 3 else os.path.join(run_dir, "report.md")
    column = int(sys.argv[4]) if len(sys.argv) > 4 else 1
    try:
        expected = recompute(run_dir, mode)
        bad = check(open(need(report)).read(), expected, column)
    except Missing as e:
        print("CANNOT CHECK %s: %s" % (report, e))
        return 1
    for b in bad:
        print("MISMATCH " + b)
    if not bad:
        print("every row matches the raw data")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
