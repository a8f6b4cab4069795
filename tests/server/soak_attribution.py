#!/usr/bin/env python3
"""Were the bots' replaced inputs in the relay soak the hostile clients' doing? (issue 20)

tests/server/relay_soak.sh runs ROOMS two-player rooms of relay_bench bots beside rounds of
hostile clients. On a loaded machine the bots' own generator falls behind and the server then
replaces (confirms without) some of their inputs, whatever the hostiles do. This script decides,
within the one run, whether the hostiles added any, by comparing like with like:

  targeted rooms   a stolen-slot hello names a live bots' room. Its window is the attack's
                   [start - margin, end + margin]; the replaced slot-frames of that room in its
                   windows are set against those of every other bots' room in the same windows
                   (rates per slot-frame: a room has 2 slots x 60 frames a second).
  hostiles' rooms  the honest clients beside a checksum liar (their own replaced frames, from
                   their summaries), against those of a control room of as many players, all
                   honest `lockroll client`s, started beside them: a joining client's first
                   frames are replaced in any room (about 9 of 600 each, measured 2026-12-06),
                   so the bots, who join the room clock at once, are no baseline for them.
  liar rounds      the bots' replaced slot-frames, all rooms, in the windows of the liar rounds
                   (a liar beside two honest clients, and a control room of three: six processes
                   started at once) against those in the windows of the control-only rounds
                   (kind control_only: the same two rooms started the same way, an honest client
                   in the liar's slot, no hostile). Both load the machine alike, so a liar that
                   stalled the server would show here, the process starts not. Not decided (a
                   line says so) when the run had no control-only round.
  any time         (information, no verdict) the bots' rate in all rooms while any hostile was
                   active (its window) against their rate outside every window, from the first
                   attack on, all replaced inputs and those the bots sent on time (not
                   generator_late), and per kind of hostile. A flood that starved the server
                   would show here, but so does the test machine: the soak's hostile rounds start
                   a dozen processes (python included) on the cores the server and the bots'
                   generator use, and rest during its sleeps, so "outside" is the quiet time of
                   the machine too (2026-12-06: the steals' windows, python and two process
                   starts, showed the highest rate in every room, targeted or not; the liar
                   rounds', five lockroll clients, the lowest). Only the like-for-like
                   comparisons above decide.

Each deciding comparison is "significant" when its observed count exceeds FACTOR (2) times the count the
baseline rate predicts plus SLACK (60 slot-frames: half a second of one room's two slots, so that
a lone hiccup on a quiet run is not called an attack). The replaced inputs attributable to
hostiles are the observed counts beyond the prediction of the three comparisons. With --strict the exit status is 1 when any
comparison is significant or any honest client was kicked.

Inputs (CSV with a header):
  --replaced  relay_bench --replaced-log: time_ms,run,room,slot,frames,generator_late (per
              second; an older log's unsent column stands for generator_late)
  --attacks   the soak's hostile actions: start_ms,end_ms,kind,room (room: a bots' room index
              for kind steal, else the hostile's own room name); kind control_only is no
              hostile, but a control-only round's window (the liar rounds' baseline)
  --honest    honest lockroll clients: room,slot,role,frames,replaced,outcome (role neighbour:
              beside a liar; control: in the all-honest room started with it; control_only: in
              a control-only round, counted only for its outcome)
  --rooms     the bots' room count; --end-ms when the bots stopped (or the server first kicked
              one: their rooms replace nothing after); --honest-kicked how many
              honest clients (bots or the liar's neighbours) were disconnected or failed.
`soak_attribution.py --selftest` checks the rules on synthetic runs (ctest: unit tier).
"""
import argparse
import csv
import os
import sys
import tempfile

FPS = 60
SLOTS = 2
# The kind of the control-only rounds in --attacks: the liar rounds' twins without a liar.
CONTROL_ONLY = "control_only"


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def merge(intervals):
    out = []
    for a, b in sorted(intervals):
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return out


def inside(t, intervals):
    return any(a <= t < b for a, b in intervals)


def span_s(intervals):
    return sum(b - a for a, b in intervals) / 1000.0


class Comparison:
    """Observed replaced slot-frames over an exposure, against a baseline rate."""

    def __init__(self, name, observed, exposure, base_count, base_exposure, factor, slack):
        self.name = name
        self.observed, self.exposure = observed, exposure
        self.base_count, self.base_exposure = base_count, base_exposure
        self.rate = observed / exposure if exposure else 0.0
        self.base_rate = base_count / base_exposure if base_exposure else 0.0
        self.expected = self.base_rate * exposure
        self.excess = max(0, round(observed - self.expected))
        self.bound = factor * self.expected + slack
        self.significant = observed > self.bound

    def line(self, baseline):
        return (f"  {self.name}: {self.observed} of {self.exposure:.0f} slot-frames replaced (rate {self.rate:.2e}) vs "
                f"{baseline} {self.base_count} of {self.base_exposure:.0f} ({self.base_rate:.2e}); expected {self.expected:.1f}, "
                f"bound {self.bound:.1f}: {'SIGNIFICANT' if self.significant else 'within the bound'}")


def analyse(replaced_rows, attacks, honest, rooms, end_ms, margin_ms=3000, factor=2.0, slack=60.0):
    """Returns (comparisons, attributable, lines, the time comparison). Only the time before
    end_ms counts (the bots' end, or their first kick: after it their rooms replace nothing)."""
    def window(a):
        return int(a["start_ms"]) - margin_ms, min(end_ms, int(a["end_ms"]) + margin_ms)
    controls = [a for a in attacks if a["kind"] == CONTROL_ONLY and window(a)[0] < end_ms]
    attacks = [a for a in attacks if a["kind"] != CONTROL_ONLY and window(a)[0] < end_ms]
    # A second bucket counts at its middle.
    samples = []
    for r in replaced_rows:
        late = r["generator_late"] if "generator_late" in r else r["unsent"]
        samples.append((int(r["time_ms"]) + 500, int(r["room"]), int(r["frames"]), int(late)))
    starts = [int(a["start_ms"]) for a in attacks]
    begin = min(starts) - margin_ms if starts else 0
    windows = merge([window(a) for a in attacks])

    # Targeted rooms: each steal's victim in its windows, against the other rooms then.
    targeted = {}
    for a in attacks:
        if a["kind"] == "steal":
            targeted.setdefault(int(a["room"]), []).append(window(a))
    t_obs = t_exp = o_obs = o_exp = 0.0
    for room, iv in targeted.items():
        iv = merge(iv)
        seconds = span_s(iv)
        t_exp += seconds * SLOTS * FPS
        o_exp += seconds * SLOTS * FPS * (rooms - 1)
        for t, r, n, _ in samples:
            if inside(t, iv):
                if r == room:
                    t_obs += n
                else:
                    o_obs += n
    comparisons = [Comparison("targeted rooms in their windows", int(t_obs), t_exp, int(o_obs), o_exp, factor, slack)]

    # The bots' rate while hostiles were active, and outside, from the first attack on: all
    # replaced inputs, and those the bots sent on time (the decision's).
    def in_span(active, on_time):
        return sum(n - (late if on_time else 0) for t, _, n, late in samples
                   if begin <= t < end_ms and inside(t, windows) == active)
    during_s = span_s(windows)
    outside_s = max(0.0, (end_ms - begin) / 1000.0 - during_s) if starts else 0.0
    per_s = rooms * SLOTS * FPS
    during_all = Comparison("all bots' rooms while hostiles were active, every replaced input", in_span(True, False),
                            during_s * per_s, in_span(False, False), outside_s * per_s, factor, slack)
    during_cmp = Comparison("all bots' rooms while hostiles were active, inputs the bots sent on time", in_span(True, True),
                            during_s * per_s, in_span(False, True), outside_s * per_s, factor, slack)

    # Honest slots in the hostiles' own rooms (the liar's neighbours), against the control rooms.
    def honest_sum(role, field):
        return sum(int(h[field]) for h in honest if h["role"] == role)
    comparisons.append(Comparison("honest slots in hostiles' rooms", honest_sum("neighbour", "replaced"),
                                  honest_sum("neighbour", "frames"), honest_sum("control", "replaced"),
                                  honest_sum("control", "frames"), factor, slack))

    # The bots in the liar rounds' windows against the control-only rounds' windows (every room:
    # a liar that stalled the server would replace inputs everywhere, as the load does).
    def all_rooms(kind_rows):
        iv = merge([window(a) for a in kind_rows])
        return sum(n for t, _, n, _ in samples if inside(t, iv)), span_s(iv) * rooms * SLOTS * FPS
    liar_obs, liar_exp = all_rooms([a for a in attacks if a["kind"] == "liar"])
    ctl_obs, ctl_exp = all_rooms(controls)
    liar_cmp = Comparison("bots in liar rounds' windows", liar_obs, liar_exp, ctl_obs, ctl_exp, factor, slack)
    decided = liar_exp > 0 and ctl_exp > 0
    if decided:
        comparisons.append(liar_cmp)

    # Per kind of hostile (information: which kind's windows carry the replaced inputs).
    by_kind = []
    for kind in sorted({a["kind"] for a in attacks + controls}):
        iv = merge([window(a) for a in attacks + controls if a["kind"] == kind])
        n_all = sum(n for t, _, n, _ in samples if inside(t, iv))
        n_on_time = sum(n - g for t, _, n, g in samples if inside(t, iv))
        exposure = span_s(iv) * per_s
        by_kind.append(f"{kind} {span_s(iv):.0f} s: {n_all / exposure if exposure else 0:.2e} all, "
                       f"{n_on_time / exposure if exposure else 0:.2e} on time")

    total = sum(n for _, _, n, _ in samples)
    late = sum(u for _, _, _, u in samples)
    attributable = sum(c.excess for c in comparisons)
    lines = [
        f"replaced slot-frames logged: {total} ({late} the bots' generator sent late or not at all: it fell behind); "
        f"{len(attacks)} hostile actions before the end, {sum(1 for a in attacks if a['kind'] == 'steal')} of them steals in "
        f"{len(targeted)} bots' rooms; windows ±{margin_ms / 1000:g} s, {during_s:.0f} s with hostiles active, {outside_s:.0f} s without",
        comparisons[0].line("other bots' rooms in the same windows"),
        comparisons[1].line("honest clients in the control rooms"),
        liar_cmp.line("control-only rounds' windows") if decided else
        f"  bots in liar rounds' windows: {liar_obs} of {liar_exp:.0f} slot-frames replaced; no control-only round to compare "
        f"with ({len(controls)} windows): not decided",
        during_all.line("outside every window").replace(": SIGNIFICANT", ": above the bound (information)"),
        during_cmp.line("outside every window").replace(": SIGNIFICANT", ": above the bound (information)"),
        "  the bots' rate in each kind's windows: " + "; ".join(by_kind),
        f"replaced inputs attributable to hostiles: {attributable} (targeted-room rate {comparisons[0].rate:.2e} vs others "
        f"{comparisons[0].base_rate:.2e} in the same windows, {int(t_obs)} vs {int(o_obs)} slot-frames)",
        (f"liar rounds vs control-only rounds: the bots' rate {liar_cmp.rate:.2e} in {len([a for a in attacks if a['kind'] == 'liar'])} "
         f"liar rounds' windows vs {liar_cmp.base_rate:.2e} in {len(controls)} control-only rounds' ({liar_obs} vs {ctl_obs} slot-frames): "
         + ("SIGNIFICANT: the liar's doing" if liar_cmp.significant else "within the bound: no worse than six honest clients' start")
         if decided else "liar rounds vs control-only rounds: not decided (no control-only round, or no liar round, before the end)"),
    ]
    return comparisons, attributable, lines, during_cmp


def verdict(comparisons, honest_kicked, strict):
    failed = [c.name for c in comparisons if c.significant]
    if honest_kicked:
        failed.append(f"{honest_kicked} honest clients kicked")
    ok = not failed
    text = "attribution: ok (no comparison beyond its bound, no honest client kicked)" if ok else \
        "attribution: " + ("FAIL: " if strict else "(not strict) ") + "; ".join(failed)
    return (ok or not strict), text


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--selftest", action="store_true")
    p.add_argument("--replaced")
    p.add_argument("--attacks")
    p.add_argument("--honest")
    p.add_argument("--rooms", type=int)
    p.add_argument("--end-ms", type=int)
    p.add_argument("--honest-kicked", type=int, default=0)
    p.add_argument("--margin-ms", type=int, default=3000)
    p.add_argument("--factor", type=float, default=2.0)
    p.add_argument("--slack", type=float, default=60.0)
    p.add_argument("--strict", action="store_true")
    a = p.parse_args(argv)
    if a.selftest:
        return selftest()
    if not (a.replaced and a.attacks and a.rooms and a.end_ms):
        print("soak_attribution: give --replaced, --attacks, --rooms and --end-ms", file=sys.stderr)
        return 2
    try:
        replaced = read_rows(a.replaced)
        attacks = read_rows(a.attacks)
        honest = read_rows(a.honest) if a.honest else []
        comparisons, _, lines, _ = analyse(replaced, attacks, honest, a.rooms, a.end_ms, a.margin_ms, a.factor, a.slack)
    except (OSError, KeyError, ValueError) as e:
        print(f"soak_attribution: {e}", file=sys.stderr)
        return 2
    print("\n".join(lines))
    ok, text = verdict(comparisons, a.honest_kicked, a.strict)
    print(text)
    return 0 if ok else 1


# --- selftest: synthetic runs, no processes ---------------------------------------------------

def synthetic(directory, name, extra_in_victims, honest_replaced=9, kicked=0, flood_everywhere=0, generator_behind=0,
              loaded=0, liar_extra=0, control_extra=0):
    """A 20-room, 200 s run: background replacements in every room (2 slot-frames a second in
    rooms 0..19, in turn), steals every 20 s at rooms 3, 5, ... with extra_in_victims slot-frames
    added to the victim in the second after each steal, and flood_everywhere added to every room
    while each round's flooder runs (generator_behind: as many, all generator_late); loaded more in
    every room every second (a loaded machine, hostiles or not); a liar round whose two honest clients had honest_replaced
    own inputs replaced each, and its control room's three 9 each. Each round ends with a 4.5 s
    round of six clients' start, a liar round in odd rounds and a control-only round in even ones,
    with liar_extra or control_extra added to every room in its middle (a stall of the server)."""
    rooms, t0 = 20, 1_700_000_000_000
    rows, attacks = [], []
    for s in range(200):
        rows.append((t0 + s * 1000, s % rooms, 2, 0))
        rows.extend((t0 + s * 1000, r, loaded, 0) for r in range(rooms) if loaded)
    for k in range(8):
        start = t0 + 20_000 + k * 20_000
        victim = (3 + 2 * k) % rooms
        attacks.append((start, start + 1500, "steal", victim))
        attacks.append((start + 2000, start + 9000, "flood", f"hostile-{k}-flood"))
        attacks.append((start + 10500, start + 15000, "liar" if k % 2 else CONTROL_ONLY, f"liar-{k}"))
        for r in range(rooms):
            if liar_extra if k % 2 else control_extra:
                rows.append((start + 12000, r, liar_extra if k % 2 else control_extra, 0))
        if extra_in_victims:
            rows.append((start + 1000, victim, extra_in_victims, 0))
        for r in range(rooms):
            if flood_everywhere:
                rows.append((start + 4000, r, flood_everywhere, 0))
            if generator_behind:
                rows.append((start + 5000, r, generator_behind, generator_behind))
    paths = {}
    for kind, header, data in (
            ("replaced", "time_ms,run,room,slot,frames,generator_late", [f"{t},0,{r},{r % 2},{n},{g}" for t, r, n, g in rows]),
            ("attacks", "start_ms,end_ms,kind,room", [f"{a},{b},{k},{r}" for a, b, k, r in attacks]),
            ("honest", "room,slot,role,frames,replaced,outcome",
             [f"liar-1,{s},neighbour,600,{honest_replaced},completed" for s in (0, 1)] +
             [f"control-1,{s},control,600,9,completed" for s in (0, 1, 2)])):
        paths[kind] = os.path.join(directory, f"{name}-{kind}.csv")
        with open(paths[kind], "w") as f:
            f.write(header + "\n" + "".join(line + "\n" for line in data))
    return ["--replaced", paths["replaced"], "--attacks", paths["attacks"], "--honest", paths["honest"], "--rooms", str(rooms),
            "--end-ms", str(t0 + 200_000), "--honest-kicked", str(kicked), "--strict"]


def analyse_synthetic(argv):
    kv = dict(zip(argv[0:-1:2], argv[1::2]))
    return analyse(read_rows(kv["--replaced"]), read_rows(kv["--attacks"]), read_rows(kv["--honest"]), int(kv["--rooms"]),
                   int(kv["--end-ms"]))


def selftest():
    failures = []
    with tempfile.TemporaryDirectory(prefix="lockroll-soak-") as d:
        cases = [
            ("background only", synthetic(d, "quiet", 0), 0),
            # 8 steals x 40 extra slot-frames in the victims: 320 beyond a background of ~0.1 per window.
            ("victims hit", synthetic(d, "hit", 40), 1),
            # A loaded machine: 10 replaced a second in every room, the victims' as the others'.
            ("loaded machine, victims as the others", synthetic(d, "loaded", 0, loaded=10), 0),
            ("loaded machine, victims hit", synthetic(d, "loaded-hit", 200, loaded=10), 1),
            # A handful in the victims is within the slack: not called an attack.
            ("victims noise", synthetic(d, "noise", 2), 0),
            ("honest neighbour of a liar hit", synthetic(d, "neighbour", 0, honest_replaced=75), 1),
            ("an honest client kicked", synthetic(d, "kicked", 0, kicked=1), 1),
            # Every room hit while the flooders run: not the victims' rooms, the time; reported
            # (below), but the machine's own load looks the same: no verdict.
            ("flood starves everyone", synthetic(d, "flood", 0, flood_everywhere=20), 0),
            # Six clients' start stalls the server as much in the control-only rounds as in the
            # liar rounds: the load's, not the liar's.
            ("liar and control-only rounds alike", synthetic(d, "starts", 0, liar_extra=30, control_extra=30), 0),
            ("liar rounds a little worse (noise)", synthetic(d, "starts-noise", 0, liar_extra=32, control_extra=30), 0),
            # The bots replaced in the liar rounds only: the liar's doing (a stall of the server).
            ("liar rounds worse than control-only", synthetic(d, "liar", 0, liar_extra=30), 1),
            ("liar rounds worse, control-only loaded too", synthetic(d, "liar-loaded", 0, liar_extra=90, control_extra=30), 1),
        ]
        for name, argv, want in cases:
            got = main(argv)
            if got != want:
                failures.append(f"{name}: exit {got}, expected {want}")
        # The attributable count: 8 x 40 extra, less the few the background predicts.
        attributable = analyse_synthetic(synthetic(d, "count", 40))[1]
        if not 300 <= attributable <= 320:
            failures.append(f"attributable {attributable}, expected about 320")
        # The time comparison counts the inputs the bots sent on time: a generator that fell
        # behind while hostiles ran is not above its bound, a starved server is.
        # The liar rounds' excess is attributable: 4 rounds x 20 rooms x 30, over a background of
        # ~1 slot-frame a window.
        attributable = analyse_synthetic(synthetic(d, "liar-count", 0, liar_extra=30))[1]
        if not 2350 <= attributable <= 2400:
            failures.append(f"liar rounds: attributable {attributable}, expected about 2,400")
        for name, kw, want in (("flood", {"flood_everywhere": 20}, True), ("behind", {"generator_behind": 20}, False)):
            during = analyse_synthetic(synthetic(d, name, 0, **kw))[3]
            if during.significant != want:
                failures.append(f"{name}: while hostiles were active, on time: above the bound {during.significant}, expected {want}")
        if main(["--rooms", "3"]) != 2:
            failures.append("missing inputs not refused with status 2")
    for f in failures:
        print(f"selftest: FAIL: {f}", file=sys.stderr)
    print("selftest:", "FAIL" if failures else "ok")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
