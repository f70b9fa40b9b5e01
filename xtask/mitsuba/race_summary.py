#!/usr/bin/env python3
"""Time to relMSE 1e-3 of each renderer on each scene of a race.

Usage: race_summary.py OUT_DIR

Reads what the race's run.sh wrote into OUT_DIR/NAME/: Mitsuba's ladder
(mitsuba-times.json: render times per spp; mitsuba-relmse.txt: `spp
relMSE` of the first render of each spp against twintrace's converged
image), twintrace's ladders (twintrace-LADDER.txt, a sampler or SAMPLER-rrHIT: `spp gpu_seconds
relMSE` per render) and the converged images' diff (converged.txt). For
each renderer the time to relMSE 1e-3 is interpolated log-log between the
two rungs of the ladder around it (median time, mean relMSE at each spp);
past the last rung it is extrapolated by relMSE ∝ 1/time and marked `*`.
A scene whose converged images disagree (diff's verdict is not PASS) is
listed but its ratios are not comparable: marked `!`.
"""
import json
import math
import os
import statistics
import sys

TARGET = 1e-3


def ladder(points):
    """(spp, seconds, relMSE) triples to one (median time, mean relMSE) a spp."""
    by = {}
    for spp, t, e in points:
        by.setdefault(spp, []).append((t, e))
    out = []
    for spp in sorted(by):
        ts = [t for t, _ in by[spp]]
        es = [e for _, e in by[spp]]
        out.append((spp, statistics.median(ts), sum(es) / len(es)))
    return out


def time_to(rungs):
    """Seconds to TARGET, and whether it was extrapolated; None if no data."""
    rungs = [r for r in rungs if r[1] > 0 and r[2] > 0]
    if len(rungs) < 2:
        return None, False
    for (s0, t0, e0), (s1, t1, e1) in zip(rungs, rungs[1:]):
        if e0 >= TARGET >= e1 and e0 != e1:
            f = math.log(e0 / TARGET) / math.log(e0 / e1)
            return math.exp(math.log(t0) + f * math.log(t1 / t0)), False
    if rungs[0][2] < TARGET:
        # Below the target at the first rung: time scales with error down.
        s, t, e = rungs[0]
        return t * e / TARGET, True
    s, t, e = rungs[-1]
    return t * e / TARGET, True


def read_rows(path, columns):
    rows = []
    if not os.path.exists(path):
        return rows
    for line in open(path):
        parts = line.split()
        if len(parts) != columns:
            continue
        try:
            rows.append(tuple(float(x) for x in parts))
        except ValueError:
            continue
    return rows


def ladders(d):
    """twintrace's ladders in D (twintrace-NAME.txt: a sampler, or
    SAMPLER-rrHIT with Russian roulette from that hit), independent first."""
    names = [f[len("twintrace-"):-len(".txt")] for f in os.listdir(d)
             if f.startswith("twintrace-") and f.endswith(".txt")]
    return sorted(names, key=lambda n: (not n.startswith("independent"), n))


def scene_row(d):
    times = json.load(open(os.path.join(d, "mitsuba-times.json")))["ladder"]
    errs = {int(s): e for s, e in read_rows(os.path.join(d, "mitsuba-relmse.txt"), 2)}
    mitsuba = [(r["spp"], r["median_s"], errs[r["spp"]]) for r in times if r["spp"] in errs]
    result = {"mitsuba": time_to(mitsuba)}
    for name in ladders(d):
        rows = read_rows(os.path.join(d, f"twintrace-{name}.txt"), 3)
        result[name] = time_to(ladder([(int(s), t, e) for s, t, e in rows]))
    verdict = "missing"
    conv = os.path.join(d, "converged.txt")
    if os.path.exists(conv):
        for line in open(conv):
            if line.startswith("verdict:"):
                verdict = line.split(":", 1)[1].strip().split()[0]
    return result, verdict


def ms(v):
    t, extrapolated = v
    if t is None:
        return "–"
    return f"{t * 1e3:.1f}{'*' if extrapolated else ''}"


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: race_summary.py OUT_DIR")
    out = sys.argv[1]
    scenes = [n for n in sorted(os.listdir(out))
              if os.path.exists(os.path.join(out, n, "mitsuba-times.json"))]
    names = []
    for n in scenes:
        names += [l for l in ladders(os.path.join(out, n)) if l not in names]
    print("| scene | converged images | Mitsuba ms | "
          + " | ".join(f"twintrace {l} ms" for l in names) + " | "
          + " | ".join(f"{l} / Mitsuba" for l in names) + " |")
    print("|---|---|---|" + "---|" * (2 * len(names)))
    for name in scenes:
        r, verdict = scene_row(os.path.join(out, name))
        mark = "" if verdict == "PASS" else "!"
        ratios = []
        for l in names:
            a, b = r.get(l, (None, False))[0], r["mitsuba"][0]
            ratios.append(f"{a / b:.2f}{mark}" if a and b else "–")
        times = [ms(r.get(l, (None, False))) for l in names]
        print(f"| {name} | {verdict} | {ms(r['mitsuba'])} | " + " | ".join(times)
              + " | " + " | ".join(ratios) + " |")

if __name__ == "__main__":
    main()
