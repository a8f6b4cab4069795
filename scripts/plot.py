#!/usr/bin/python3
"""Plots for lockroll's harness outputs (matplotlib, Agg backend: no display needed).

  plot.py compare DIR   reads DIR/lockstep/ and DIR/rollback/ (frames.csv, summary.json,
                        events.csv, timesync.csv), writes DIR/error_vs_time.png,
                        DIR/rollback_depth.png, DIR/tick_rate.png and DIR/time_sync.png
  plot.py sweep DIR     reads DIR/sweep.csv, writes DIR/sweep.png
  plot.py selftest      plots synthetic CSVs in a temporary directory and checks the results
                        and the error reporting (run by CTest)

frames.csv columns: frame,time_s,mean_error,max_error,rollbacks,max_rollback_depth,ticks_per_second
  (one row per frame; rollbacks: how many clients' rollbacks ended on that displayed frame,
  max_rollback_depth the deepest of them). The depth histogram comes from DIR/MODE/summary.json
  (rollbacks.depth_histogram), which counts every rollback.
sweep.csv columns:  input_delay,prediction,latency_ms,mean_error,max_error,input_latency_ms,
                    cpu_us_per_tick,ticks_per_second,stall_fraction (one row per grid point;
                    the lowest-error frontier only runs through rows stalling <= 5 % of ticks)

Bad input (missing file or column, a value that is not a number) prints a message naming the
file, line and column and exits with status 2. PNGs are written to a temporary file in the same
directory and renamed into place, so a reader never sees half a file.
"""

import argparse
import csv
import json
import math
import os
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.lines  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402  (after use())
from matplotlib.ticker import MaxNLocator  # noqa: E402

FRAMES_COLUMNS = ["frame", "time_s", "mean_error", "max_error", "rollbacks", "max_rollback_depth",
                  "ticks_per_second"]
SWEEP_COLUMNS = ["input_delay", "prediction", "latency_ms", "mean_error", "max_error",
                 "input_latency_ms", "cpu_us_per_tick", "ticks_per_second", "stall_fraction"]
# A configuration that stalls on more than this share of its ticks does not hold the tick rate;
# it can never be the "lowest error" choice, however little error it shows.
STALL_LIMIT = 0.05
MODES = ("lockstep", "rollback")
COLORS = {"lockstep": "#1f77b4", "rollback": "#d62728"}
# Errors span 0 .. ~1 m with interesting detail near 1e-4: a symmetric log axis shows zeros and
# both scales; below this threshold it is linear.
ERROR_LINTHRESH = 1e-6


class InputError(Exception):
    """A problem with the input files, reported to the user (exit status 2)."""


def read_csv(path, columns):
    """Returns {column: [float, ...]} for the required columns (extra columns are ignored)."""
    if not os.path.isfile(path):
        raise InputError(f"{path}: file not found")
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None:
            raise InputError(f"{path}: empty file (expected a header line: {','.join(columns)})")
        header = [h.strip() for h in reader.fieldnames]
        missing = [c for c in columns if c not in header]
        if missing:
            raise InputError(f"{path}: missing column(s) {', '.join(missing)} "
                             f"(header has: {','.join(header)})")
        data = {c: [] for c in columns}
        for row in reader:
            row = {k.strip(): v for k, v in row.items() if k is not None}
            for c in columns:
                text = (row.get(c) or "").strip()
                try:
                    value = float(text)
                except ValueError:
                    raise InputError(f"{path}:{reader.line_num}: column {c}: "
                                     f"'{text}' is not a number") from None
                data[c].append(value)
    if not data[columns[0]]:
        raise InputError(f"{path}: no data rows")
    return data


def save(fig, path):
    """Writes the figure atomically: temporary file in the same directory, then rename."""
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".plot-", suffix=".png", dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, format="png", dpi=120)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    finally:
        plt.close(fig)
    print(path)


def summary_line(d):
    mean = sum(d["mean_error"]) / len(d["mean_error"])
    worst = max(d["max_error"])
    return f"mean {mean:.3g} m, max {worst:.3g} m"


# ---- compare --------------------------------------------------------------------------------

EVENT_KINDS = (("loss", "datagram lost", "#7f7f7f"), ("stall", "stalled tick", "#ff7f0e"),
               ("rollback", "rollback", "#d62728"), ("correction", "visual correction", "#9467bd"),
               ("time_sync_wait", "time-sync wait", "#2ca02c"), ("delay_change", "input delay changed", "#17becf"))


def read_events(path):
    """events.csv as {kind: [time_s, ...]}; {} when the file is missing (older runs)."""
    events = {k: [] for k, _, _ in EVENT_KINDS}
    if not os.path.isfile(path):
        return events
    with open(path, newline="") as f:
        for line, row in enumerate(csv.DictReader(f), start=2):
            try:
                t = float(row["time_s"])
            except (KeyError, TypeError, ValueError):
                raise InputError(f"{path}:{line}: column time_s: not a number") from None
            events.setdefault(row.get("kind", ""), []).append(t)
    return events


def plot_error_vs_time(runs, out, events=None):
    """Mean and max error against run time, and below them on the same time axis what causes
    the spikes: losses, stalls, rollbacks, corrections and time-sync waits of the rollback run."""
    events = events or {}
    fig, axes = plt.subplots(3, 1, figsize=(10, 8.5), sharex=True, gridspec_kw={"height_ratios": [3, 3, 2]})
    for ax, column, title in ((axes[0], "mean_error", "mean positional error between clients"),
                              (axes[1], "max_error", "max positional error between clients")):
        for mode, d in runs.items():
            ax.plot(d["time_s"], d[column], color=COLORS[mode], linewidth=1.0,
                    label=f"{mode} ({summary_line(d)})" if column == "mean_error" else mode)
        ax.set_yscale("symlog", linthresh=ERROR_LINTHRESH)
        ax.set_ylim(bottom=0)
        ax.set_ylabel("error (m)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
    # Causes, one lane each, on the same time axis.
    ax = axes[2]
    for lane, (kind, label, color) in enumerate(EVENT_KINDS):
        times = events.get(kind, [])
        ax.plot(times, [lane] * len(times), "|", color=color, markersize=9, alpha=0.6)
    ax.set_yticks(range(len(EVENT_KINDS)))
    ax.set_yticklabels([f"{label} ({len(events.get(kind, []))})" for kind, label, _ in EVENT_KINDS], fontsize=7)
    ax.set_ylim(-0.6, len(EVENT_KINDS) - 0.4)
    ax.set_title("rollback run: what happened (all clients)", fontsize=10)
    ax.grid(True, axis="x", alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    axes[1].legend(loc="upper left", fontsize=8)
    axes[2].set_xlabel("run time (s)")
    fig.suptitle("Error against run time: lockstep vs rollback")
    fig.tight_layout()
    save(fig, out)


def depth_histogram(directory, mode):
    """summary.json's rollbacks.depth_histogram: [count of rollbacks of depth d, ...]."""
    path = os.path.join(directory, mode, "summary.json")
    if not os.path.isfile(path):
        raise InputError(f"{path}: file not found")
    try:
        with open(path) as f:
            hist = json.load(f)["rollbacks"]["depth_histogram"]
    except (ValueError, KeyError, TypeError) as e:
        raise InputError(f"{path}: no rollbacks.depth_histogram ({e})") from None
    if not all(isinstance(x, int) and x >= 0 for x in hist):
        raise InputError(f"{path}: rollbacks.depth_histogram must hold non-negative integers")
    return hist


def plot_rollback_depth(runs, out, directory):
    """Histogram of every rollback's depth, from summary.json (frames.csv only holds the deepest
    rollback per frame, which undercounts). Returns the title, for the selftest."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    hist = depth_histogram(directory, "rollback")
    total = sum(hist[1:])
    if total:
        top = max(d for d, n in enumerate(hist) if n and d > 0)
        ax.bar(range(1, top + 1), hist[1:top + 1], color=COLORS["rollback"], edgecolor="black", linewidth=0.5)
        mean = sum(d * n for d, n in enumerate(hist)) / total
        title = f"Rollback depth: {total} rollbacks, mean depth {mean:.2f}, max {top} frames"
        ax.set_xlim(0.4, top + 0.6)
    else:
        ax.text(0.5, 0.5, "no rollbacks", ha="center", va="center", transform=ax.transAxes)
        title = "Rollback depth: no rollbacks"
    ax.set_title(title, fontsize=10)
    lock = sum(depth_histogram(directory, "lockstep")[1:])
    ax.text(0.99, 0.97, f"lockstep: {lock} rollbacks", ha="right", va="top",
            transform=ax.transAxes, fontsize=8, color=COLORS["lockstep"])
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("frames resimulated per rollback")
    ax.set_ylabel("rollbacks (all clients)")
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    save(fig, out)
    return title


TIMESYNC_COLUMNS = ["time_s", "client", "frame", "frames_ahead", "wait_frames"]


def plot_time_sync(d, out):
    """Each client's frame advantage over the slowest peer, and the waits time sync ordered."""
    fig, ax = plt.subplots(figsize=(10, 4.5))
    clients = sorted(set(int(c) for c in d["client"]))
    cmap = plt.get_cmap("tab10")
    for c in clients:
        idx = [i for i, x in enumerate(d["client"]) if int(x) == c]
        ax.plot([d["time_s"][i] for i in idx], [d["frames_ahead"][i] for i in idx], linewidth=0.9,
                color=cmap(c % 10), label=f"client {c}")
        waits = [i for i in idx if d["wait_frames"][i] > 0]
        if waits:
            ax.plot([d["time_s"][i] for i in waits], [d["frames_ahead"][i] for i in waits], "v",
                    color=cmap(c % 10), markersize=7, markeredgecolor="black")
    ax.plot([], [], "v", color="0.6", markeredgecolor="black", label="wait ordered (adjustment)")
    ax.set_xlabel("run time (s)")
    ax.set_ylabel("frames ahead of slowest peer")
    ax.set_title("Time sync: frame advantage and adjustments (rollback run)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=7, ncol=2)
    fig.tight_layout()
    save(fig, out)


def plot_tick_rate(runs, out):
    fig, ax = plt.subplots(figsize=(10, 4.5))
    for mode, d in runs.items():
        rates = d["ticks_per_second"]
        ax.plot(d["time_s"], rates, color=COLORS[mode], linewidth=1.0,
                label=f"{mode} (mean {sum(rates) / len(rates):.1f}, min {min(rates):.1f})")
    ax.set_xlabel("run time (s)")
    ax.set_ylabel("ticks per second")
    highest = max(max(d["ticks_per_second"]) for d in runs.values())
    ax.set_ylim(0, max(highest, 1.0) * 1.1)
    ax.set_title("Effective tick rate over time", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    save(fig, out)


def compare(directory):
    runs = {mode: read_csv(os.path.join(directory, mode, "frames.csv"), FRAMES_COLUMNS)
            for mode in MODES}
    plot_error_vs_time(runs, os.path.join(directory, "error_vs_time.png"),
                       read_events(os.path.join(directory, "rollback", "events.csv")))
    sync_path = os.path.join(directory, "rollback", "timesync.csv")
    if os.path.isfile(sync_path):
        plot_time_sync(read_csv(sync_path, TIMESYNC_COLUMNS), os.path.join(directory, "time_sync.png"))
    plot_rollback_depth(runs, os.path.join(directory, "rollback_depth.png"), directory)
    plot_tick_rate(runs, os.path.join(directory, "tick_rate.png"))


# ---- sweep ----------------------------------------------------------------------------------

def pareto(points):
    """Points (x, y, ...) not beaten on both x and y (lower is better), sorted by x."""
    front, best = [], math.inf
    for p in sorted(points, key=lambda p: (p[0], p[1])):
        if p[1] < best:
            front.append(p)
            best = p[1]
    return front


def holds_tick_rate(row):
    return row["stall_fraction"] <= STALL_LIMIT


def frontier(rows):
    """The lowest-error-at-each-input-latency front over sweep rows (dicts) that hold the tick
    rate: (input_latency_ms, mean_error, row) sorted by latency."""
    return pareto([(r["input_latency_ms"], r["mean_error"], r) for r in rows if holds_tick_rate(r)])


def read_optional_column(path, column, count):
    """A 0/1 column that older files lack (then all 0)."""
    with open(path, newline="") as f:
        values = [row.get(column) for row in csv.DictReader(f)]
    return [v is not None and v.strip() == "1" for v in values][:count] + [False] * max(0, count - len(values))


def sweep(directory):
    path = os.path.join(directory, "sweep.csv")
    d = read_csv(path, SWEEP_COLUMNS)
    rows = list(zip(*(d[c] for c in SWEEP_COLUMNS)))
    adaptive = read_optional_column(path, "adaptive", len(rows))
    latencies = sorted(set(d["latency_ms"]))
    cols = min(3, len(latencies))
    nrows = math.ceil(len(latencies) / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(5.0 * cols + 1.5, 4.4 * nrows), squeeze=False,
                             sharey=True, constrained_layout=True)
    cpu = d["cpu_us_per_tick"]
    norm = matplotlib.colors.Normalize(vmin=min(cpu), vmax=max(cpu) if max(cpu) > min(cpu) else min(cpu) + 1)
    markers = "osD^v<>ph*"
    predictions = sorted(set(d["prediction"]))
    top = max(d["mean_error"])
    for i, latency in enumerate(latencies):
        ax = axes[i // cols][i % cols]
        pts = [r for r in rows if r[2] == latency]
        for k, w in enumerate(predictions):
            sel = [r for r in pts if r[1] == w]
            ax.scatter([r[5] for r in sel], [r[3] for r in sel], c=[r[6] for r in sel], cmap="viridis",
                       norm=norm, marker=markers[k % len(markers)], s=46, edgecolors="black",
                       linewidths=0.4)
            for r, a in zip(sel, [adaptive[rows.index(r)] for r in sel]):
                ax.annotate("adaptive" if a else f"D{int(r[0])}", (r[5], r[3]), textcoords="offset points",
                            xytext=(4, 3), fontsize=6, alpha=0.9 if a else 0.7, color="C1" if a else "black")
        stalled = [r for r in pts if r[8] > STALL_LIMIT]
        if stalled:
            ax.scatter([r[5] for r in stalled], [r[3] for r in stalled], s=140, facecolors="none",
                       edgecolors="red", linewidths=0.9)
        front = frontier([dict(zip(SWEEP_COLUMNS, r)) for r in pts])
        ax.step([p[0] for p in front], [p[1] for p in front], where="post", color="gray",
                linewidth=0.8, linestyle="--")
        ax.set_yscale("symlog", linthresh=ERROR_LINTHRESH)
        ax.set_ylim(0, top * 4 if top > 0 else 1e-5)
        ax.set_title(f"one-way latency {latency:g} ms", fontsize=10)
        ax.set_xlabel("input latency (ms)")
        if i % cols == 0:
            ax.set_ylabel("displayed mean error (m)")
        ax.grid(True, alpha=0.3)
    for j in range(len(latencies), nrows * cols):
        axes[j // cols][j % cols].set_visible(False)
    # One legend for the shapes (colour is CPU, so legend markers are neutral grey).
    handles = [matplotlib.lines.Line2D([], [], linestyle="", marker=markers[k % len(markers)], color="0.6",
                                       markeredgecolor="black", markersize=7,
                                       label="lockstep (W=0)" if w == 0 else f"prediction W={int(w)}")
               for k, w in enumerate(predictions)]
    handles.append(matplotlib.lines.Line2D([], [], color="gray", linestyle="--", linewidth=0.8,
                                           label=f"lowest error at that input latency (stalls <= {STALL_LIMIT:.0%})"))
    handles.append(matplotlib.lines.Line2D([], [], linestyle="", marker="o", markerfacecolor="none",
                                           markeredgecolor="red", markersize=9,
                                           label=f"stalls on > {STALL_LIMIT:.0%} of ticks"))
    axes[0][0].legend(handles=handles, fontsize=7, loc="upper right")
    bar = fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap="viridis"), ax=axes, shrink=0.9)
    bar.set_label("CPU per tick (µs)")
    fig.suptitle("Input delay D × prediction window W: displayed error vs input latency (colour: CPU per tick)",
                 fontsize=11)
    save(fig, os.path.join(directory, "sweep.png"))


# ---- selftest -------------------------------------------------------------------------------

def write_synthetic(directory):
    """Small, deterministic CSVs in the harness's formats."""
    import random
    rng = random.Random(1)
    for mode in MODES:
        os.makedirs(os.path.join(directory, mode), exist_ok=True)
        with open(os.path.join(directory, mode, "frames.csv"), "w") as f:
            f.write(",".join(FRAMES_COLUMNS) + "\n")
            for frame in range(240):
                depth = rng.choice([0, 0, 0, 1, 2, 5]) if mode == "rollback" else 0
                worst = rng.expovariate(20) if depth else 0.0
                f.write(f"{frame},{frame / 60:.6f},{worst / 50:.6g},{worst:.6g},{1 if depth else 0},{depth},"
                        f"{60 - rng.random() * (0.5 if mode == 'rollback' else 0.1):.3f}\n")
    with open(os.path.join(directory, "rollback", "events.csv"), "w") as f:
        f.write("time_s,client,frame,kind,value\n")
        for frame in range(0, 240, 7):
            f.write(f"{frame / 60:.6f},{frame % 2},{frame},{EVENT_KINDS[frame % 5][0]},1\n")
    with open(os.path.join(directory, "rollback", "timesync.csv"), "w") as f:
        f.write(",".join(TIMESYNC_COLUMNS) + "\n")
        for frame in range(240):
            for c in range(2):
                f.write(f"{frame / 60:.6f},{c},{frame},{(frame % 60) / 30 * (1 if c else -1):.2f},"
                        f"{2 if frame % 60 == 59 else 0}\n")
    # The depth histogram of every rollback (what summary.json counts), deliberately unlike
    # the per-frame maxima in frames.csv: 17 rollbacks, mean depth 28 / 17 = 1.65.
    for mode, hist in (("lockstep", [0]), ("rollback", [0, 10, 5, 0, 2])):
        with open(os.path.join(directory, mode, "summary.json"), "w") as f:
            json.dump({"rollbacks": {"depth_histogram": hist}}, f)
    with open(os.path.join(directory, "sweep.csv"), "w") as f:
        f.write(",".join(SWEEP_COLUMNS) + ",adaptive\n")
        for latency in (28.5, 57.0, 150.0):
            for delay in range(5):
                for window in (0, 2, 8):
                    short = max(0, math.ceil(latency / 16.7) - delay)
                    error = 0.0 if window == 0 else 1e-5 * short * short
                    stall = min(0.9, 0.2 * short) if window == 0 else 0.0
                    f.write(f"{delay},{window},{latency},{error:.6g},{error * 100:.6g},"
                            f"{(delay + (short if window == 0 else 0)) * 16.7:.2f},{20 + 5 * min(window, short)},"
                            f"{60 * (1 - stall):.3f},{stall:.4f},{1 if delay == 4 else 0}\n")


def selftest():
    failures = []
    with tempfile.TemporaryDirectory(prefix="lockroll-plot-") as directory:
        write_synthetic(directory)
        if main(["compare", directory]) != 0 or main(["sweep", directory]) != 0:
            failures.append("plotting synthetic CSVs failed")
        for name in ("error_vs_time.png", "rollback_depth.png", "tick_rate.png", "time_sync.png", "sweep.png"):
            path = os.path.join(directory, name)
            if not os.path.isfile(path):
                failures.append(f"{name}: not written")
                continue
            with open(path, "rb") as f:
                if f.read(8) != b"\x89PNG\r\n\x1a\n":
                    failures.append(f"{name}: not a PNG")
        runs = {mode: read_csv(os.path.join(directory, mode, "frames.csv"), FRAMES_COLUMNS) for mode in MODES}
        title = plot_rollback_depth(runs, os.path.join(directory, "rollback_depth.png"), directory)
        if "17 rollbacks, mean depth 1.65, max 4" not in (title or ""):
            failures.append(f"rollback_depth.png counts something else than summary.json: {title!r}")
        # The frontier never runs through a configuration that stalls: lockstep at delay 0 shows
        # no error and little input latency, but at 100 ms it stalls most ticks.
        stalled = {"input_delay": 0, "prediction": 0, "latency_ms": 100, "mean_error": 0.0, "max_error": 0.0,
                   "input_latency_ms": 5.0, "cpu_us_per_tick": 10, "ticks_per_second": 19.7,
                   "stall_fraction": 0.67}
        held = dict(stalled, prediction=8, input_delay=2, mean_error=1e-4, input_latency_ms=40.0,
                    ticks_per_second=60, stall_fraction=0.0)
        front = [p[2] for p in frontier([stalled, held])]
        if front != [held]:
            failures.append(f"the lowest-error frontier includes a stalling configuration: {front}")
        leftovers = [n for n in os.listdir(directory) if n.startswith(".plot-")]
        if leftovers:
            failures.append(f"temporary files left behind: {leftovers}")
        # Bad input: a clear message and status 2, never a traceback.
        with open(os.path.join(directory, "rollback", "frames.csv"), "a") as f:
            f.write("240,4.0,oops,0,0,0,60\n")
        if main(["compare", directory]) != 2:
            failures.append("a non-numeric value was not rejected with status 2")
        os.remove(os.path.join(directory, "sweep.csv"))
        if main(["sweep", directory]) != 2:
            failures.append("a missing sweep.csv was not rejected with status 2")
    for f in failures:
        print(f"selftest: FAIL: {f}", file=sys.stderr)
    print("selftest: " + ("FAILED" if failures else "ok"))
    return 1 if failures else 0


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("compare", help="lockstep vs rollback plots").add_argument("dir")
    sub.add_parser("sweep", help="trade-off surface of a sweep").add_argument("dir")
    sub.add_parser("selftest", help="check the plots on synthetic data")
    args = parser.parse_args(argv)
    if args.command == "selftest":
        return selftest()
    if not os.path.isdir(args.dir):
        print(f"plot.py {args.command}: {args.dir}: not a directory", file=sys.stderr)
        return 2
    try:
        compare(args.dir) if args.command == "compare" else sweep(args.dir)
    except InputError as e:
        print(f"plot.py {args.command}: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
