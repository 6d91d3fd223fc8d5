#!/usr/bin/env python3
"""When a settling scene comes to rest, from the kinetic energy of its steps.csv (issue #8).

Why: the membrane stack's target ("rest in at most half the penalty method's time, no oscillation
after first rest") needs a rule that a churning contact surface can meet or miss by a number, and
the same rule every session. This is session 9's criterion (docs/experiments.md "Session 9"), used
by hand with throwaway scripts in sessions 9 and 12 and shipped in session 13:

- peak: the largest kinetic energy of the run (the landing);
- first rest at level p: the first step after the peak from which the KE stays below p x peak for
  `hold` seconds (100 steps of 1 ms) (0.1 s: about ten periods of the contact mode that churns); its time column;
- oscillation after first rest: the largest KE after the first rest (to the end), in % of the peak;
- late KE: the largest KE of the last `late` seconds, in % of the peak and in J.

Input: steps.csv of `pliant run` (columns time, kinetic_energy) or of `pliant experiment`
(surface/ or penalty/steps.csv: time, kinetic). With --vtu DIR (the run's `--vtu` frames), also each
body's centre (mean of its vertices) in the first and last frame (the largest sideways move: does a
body slide off; the vertical moves: settling) and how many bodies are at rest in the last frame
(every velocity exactly zero: asleep, or fully clamped).

Usage:
    scripts/rest_metrics.py RUN/steps.csv [RUN2/steps.csv ...] [--vtu] [--hold 0.1] [--late 0.2]
    scripts/rest_metrics.py --self-test
"""
import argparse
import csv
import glob
import os
import re
import sys


def read_series(path):
    """(times, kinetic energies) of a steps.csv."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return [], []
    key = "kinetic_energy" if "kinetic_energy" in rows[0] else "kinetic"
    return [float(r["time"]) for r in rows], [float(r[key]) for r in rows]


def first_rest(times, ke, level, hold):
    """Index of the first step after the peak from which KE < level x peak for `hold` seconds
    (the whole hold inside the run), or None."""
    if not ke:
        return None
    peak_index = max(range(len(ke)), key=lambda i: ke[i])
    bound = level * ke[peak_index]
    dt = times[1] - times[0] if len(times) > 1 else 0.0  # a step's length: 100 steps of 1 ms hold 0.1 s
    run_start = None  # first index of the current run of steps below the bound
    for i in range(peak_index + 1, len(ke)):
        if ke[i] < bound:
            if run_start is None:
                run_start = i
            if times[i] - times[run_start] + dt >= hold - 1e-9:
                return run_start
        else:
            run_start = None
    return None


def metrics(times, ke, hold=0.1, late=0.2, levels=(0.01, 0.05, 0.10)):
    """The criterion's numbers for one run (see the module's doc)."""
    peak = max(ke)
    out = {"peak": peak, "peak_time": times[ke.index(peak)], "end_time": times[-1]}
    for level in levels:
        i = first_rest(times, ke, level, hold)
        tag = f"{level * 100:g}%"
        out[f"first_rest_{tag}"] = None if i is None else times[i]
        if level == levels[0]:
            after = ke[i + 1:] if i is not None else []
            out["after_max_pct"] = None if i is None else (100.0 * max(after) / peak if after else 0.0)
    late_values = [k for t, k in zip(times, ke) if t > times[-1] - late + 1e-12]
    out["late_max_J"] = max(late_values)
    out["late_max_pct"] = 100.0 * max(late_values) / peak
    return out


def read_vtu(path):
    """Points and velocities of an ASCII .vtu written by pliant (sim/io/vtu_writer.cpp)."""
    text = open(path).read()

    def array(name_pattern):
        m = re.search(r'<DataArray[^>]*' + name_pattern + r'[^>]*>(.*?)</DataArray>', text, re.S)
        values = [float(v) for v in m.group(1).split()]
        return [values[k:k + 3] for k in range(0, len(values), 3)]

    points_block = re.search(r"<Points>(.*?)</Points>", text, re.S).group(1)
    pv = [float(v) for v in re.search(r">(.*?)</DataArray>", points_block, re.S).group(1).split()]
    points = [pv[k:k + 3] for k in range(0, len(pv), 3)]
    return points, array(r'Name="velocity"')


def vtu_bodies(vtu_dir):
    """Per body name: (first frame file, last frame file)."""
    frames = {}
    for path in sorted(glob.glob(os.path.join(vtu_dir, "*.vtu"))):
        name = re.sub(r"_\d+\.vtu$", "", os.path.basename(path))
        frames.setdefault(name, []).append(path)
    return {name: (paths[0], paths[-1]) for name, paths in frames.items()}


def centre(points):
    n = len(points)
    return [sum(p[k] for p in points) / n for k in range(3)]


def body_report(vtu_dir):
    """Per body: centre in the first and last frame, and whether the last frame is at rest."""
    rows = []
    for name, (first, last) in sorted(vtu_bodies(vtu_dir).items()):
        p0, _ = read_vtu(first)
        p1, v1 = read_vtu(last)
        at_rest = all(c == 0.0 for v in v1 for c in v)
        rows.append((name, centre(p0), centre(p1), at_rest))
    return rows


def fmt(value, digits=3):
    return "n/a" if value is None else f"{value:.{digits}f}"


def self_test():
    """Synthetic series with known answers (a hand-built reference for each rule)."""
    dt = 0.001
    times = [dt * (i + 1) for i in range(1000)]
    # Peak 1.0 at step 49; 0.5 until step 199; 0.005 (below 1 %) from step 200 to 349; one spike
    # of 0.02 (2 %) at step 350; below 1 % again from 351 to the end.
    ke = [0.1] * 49 + [1.0] + [0.5] * 150 + [0.005] * 150 + [0.02] + [0.004] * 649
    assert len(ke) == 1000
    m = metrics(times, ke)
    assert m["peak"] == 1.0 and abs(m["peak_time"] - 0.050) < 1e-12, m
    assert abs(m["first_rest_1%"] - times[200]) < 1e-12, m  # 150 steps below: holds 0.1 s
    assert abs(m["after_max_pct"] - 2.0) < 1e-12, m          # the spike after first rest
    assert abs(m["first_rest_5%"] - times[200]) < 1e-12, m
    assert abs(m["late_max_pct"] - 0.4) < 1e-12, m
    # A run below 1 % for 99 steps only (shorter than the hold) is not a rest; the next one is.
    ke2 = [1.0] + [0.005] * 99 + [0.5] + [0.005] * 899
    assert abs(first_rest(times, ke2, 0.01, 0.1) - 101) < 1e-12
    # Nothing after the peak below the level: no first rest, no oscillation number.
    m3 = metrics(times, [0.5] * 999 + [1.0])
    assert m3["first_rest_1%"] is None and m3["after_max_pct"] is None, m3
    # A rest that begins too close to the end to be held for 0.1 s does not count.
    ke4 = [1.0] + [0.5] * 949 + [0.001] * 50
    assert first_rest(times, ke4, 0.01, 0.1) is None
    print("rest_metrics self-test: ok")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("steps", nargs="*", help="steps.csv files")
    parser.add_argument("--hold", type=float, default=0.1, help="seconds the KE must stay below the level")
    parser.add_argument("--late", type=float, default=0.2, help="the late window at the end (s)")
    parser.add_argument("--vtu", action="store_true", help="also read RUN/vtu/ beside each steps.csv")
    parser.add_argument("--self-test", action="store_true", help="check the rules on synthetic series")
    args = parser.parse_args()
    if args.self_test:
        self_test()
        return 0
    print("run | end s | peak J (t s) | first rest 1% / 5% / 10% (s) | max KE after 1% rest, % peak | "
          "late max % peak (J)" + (" | bodies at rest at the end | largest sideways centre move mm (body) | "
                                       "vertical centre moves mm" if args.vtu else ""))
    for path in args.steps:
        times, ke = read_series(path)
        m = metrics(times, ke, args.hold, args.late)
        line = (f"{path} | {m['end_time']:.3f} | {m['peak']:.4g} ({m['peak_time']:.3f}) | "
                f"{fmt(m['first_rest_1%'])} / {fmt(m['first_rest_5%'])} / {fmt(m['first_rest_10%'])} | "
                f"{fmt(m['after_max_pct'], 2)} | {m['late_max_pct']:.2f} ({m['late_max_J']:.3g})")
        if args.vtu:
            rows = body_report(os.path.join(os.path.dirname(path), "vtu"))
            resting = sum(1 for r in rows if r[3])
            # Sideways (x, y) is sliding; down (z) is the stack settling and sagging.
            sideways = [1000.0 * ((r[2][0] - r[1][0]) ** 2 + (r[2][1] - r[1][1]) ** 2) ** 0.5 for r in rows]
            down = [1000.0 * (r[2][2] - r[1][2]) for r in rows]
            i = max(range(len(rows)), key=lambda k: sideways[k])
            line += (f" | {resting} of {len(rows)} | {sideways[i]:.1f} ({rows[i][0]}) | "
                     f"{min(down):.1f} .. {max(down):.1f}")
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
