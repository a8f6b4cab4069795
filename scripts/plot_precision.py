#!/usr/bin/python3
"""Work-precision plot for `lockroll precision` (docs/stability.md).

usage: plot_precision.py PRECISION.CSV OUT.PNG

One column per case. Top row: error against microseconds per step; bottom row: the same error
against microseconds per simulated second (what a fixed amount of game time costs, which is the
fair comparison between tick rates). One curve per solver setting (iterations x substeps), its
points the tick rates 240..20 Hz; for the default solver colour is the iteration count and line
style the substep count; the opt-in ballistic+continuous mode is drawn in red with square markers.
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LABELS = {
    "max_position_error_m": "max position error vs reference (m)",
    "max_energy_drift_rel": "max |E(t) - E(0)| / E(0)",
}
STYLES = {1: "-", 2: "--", 4: ":", 8: "-."}


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1], newline="")))
    if not rows:
        sys.exit("plot_precision.py: no rows in " + sys.argv[1])
    cases = list(dict.fromkeys(r["case"] for r in rows))
    iters = sorted({int(r["iterations"]) for r in rows if r.get("solver", "default") == "default"})
    cmap = plt.get_cmap("viridis")
    colour = {it: cmap(i / max(1, len(iters) - 1)) for i, it in enumerate(iters)}
    fig, axes = plt.subplots(2, len(cases), figsize=(5.2 * len(cases), 8.5), squeeze=False)
    for col, case in enumerate(cases):
        curves = defaultdict(list)
        metric = None
        for r in rows:
            if r["case"] != case:
                continue
            metric = r["metric"]
            curves[(r.get("solver", "default"), int(r["iterations"]), int(r["substeps"]))].append(r)
        for row, xkey in enumerate(("us_per_step", "us_per_sim_second")):
            ax = axes[row][col]
            for (solver, it, sub), pts in sorted(curves.items(), key=lambda kv: (kv[0][0] != "default", kv[0][1:])):
                pts = sorted(pts, key=lambda r: int(r["tick_rate"]))
                xs = [float(p[xkey]) for p in pts]
                ys = [max(float(p["error"]), 1e-12) for p in pts]
                if solver == "default":
                    ax.plot(xs, ys, STYLES.get(sub, "-"), color=colour[it], marker="o", markersize=3, linewidth=1.2,
                            label=f"{it} it, {sub} sub")
                else:
                    ax.plot(xs, ys, STYLES.get(sub, "-"), color="tab:red", marker="s", markersize=3, linewidth=1.4,
                            label=f"{solver}, {it} it, {sub} sub")
                if solver == "default" and it == iters[-1] and sub == 1:
                    for p, x, y in zip(pts, xs, ys):
                        ax.annotate(p["tick_rate"] + " Hz", (x, y), fontsize=7, textcoords="offset points", xytext=(3, 3))
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.grid(True, which="both", alpha=0.3)
            ax.set_xlabel("µs per step" if row == 0 else "µs per simulated second")
            ax.set_ylabel(LABELS.get(metric, metric))
            if row == 0:
                ax.set_title(case)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=6, fontsize=8)
    fig.suptitle("lockroll work-precision: Q32.32 engine, error against the same algorithm on double")
    fig.tight_layout(rect=(0, 0.1, 1, 0.96))
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
