#!/usr/bin/env python3
"""Per-step work of a scene run: instructions per World::step from callgrind, joined with steps.csv.

Why: on this shared machine a step's time is mostly the load's noise (the slowest 1% of steps are
different steps in every run), but callgrind's instruction counts are repeatable. Dumping after
every World::step gives one count per step, which this script lines up with the step's work
(CG iterations, colliding vertices) to say what the expensive steps have in common (docs/interaction.md,
"Session 11").

Usage (the bench's steps are the run's steps: warm-up W untimed, then the timed ones):
    valgrind --tool=callgrind --dump-after='pliant::World::step*' --callgrind-out-file=DIR/cg.out \\
        build/apps/pliant bench assets/scenes/probe.json --steps 600 --warm-up 300 --no-variants
    build/apps/pliant run assets/scenes/probe.json --out RUN --no-frames --quiet
    scripts/step_work.py DIR/cg.out RUN/steps.csv --first 300 --last 899

Dump k (cg.out.k) covers step k-1. Prints the percentiles of instructions per step, a least-squares
fit  instructions = a + b * CG iterations + c * (instructions in the K' row sums), the slowest 2% of
steps with their work, and the steps that called malloc. With --functions N (session 12), also the N
functions with the most own instructions in the p50 band and the p99 band of steps.
"""
import argparse
import csv
import re
import statistics

NAME = re.compile(r"\((\d+)\)(?: (.*))?")


def read_dumps(prefix, count):
    """Per dump: total instructions, self instructions per function, calls to malloc."""
    names = {}  # callgrind compresses a function's name to "(id)" after its first use, across files

    def name(token):
        m = NAME.match(token)
        if not m:
            return token
        if m.group(2):
            names[m.group(1)] = m.group(2)
        return names.get(m.group(1), "?")

    dumps = []
    for part in range(1, count + 1):
        total, mallocs, fn, callee, after_calls = 0, 0, None, None, False
        own = {}
        with open(f"{prefix}.{part}") as f:
            for line in f:
                if line.startswith("summary:"):
                    total = int(line.split()[1])
                elif line.startswith("fn="):
                    fn = name(line[3:].strip())
                elif line.startswith("cfn="):
                    callee = name(line[4:].strip())
                elif line.startswith("calls="):
                    after_calls = True  # the next cost line is the call's inclusive cost
                    if callee == "malloc":
                        mallocs += int(line[6:].split()[0])
                elif line[:1].isdigit() or line[:1] in "+-*":
                    fields = line.split()
                    if after_calls:
                        after_calls = False
                    elif len(fields) >= 2 and fn:
                        own[fn] = own.get(fn, 0) + int(fields[1])
        dumps.append({"total": total, "mallocs": mallocs, "own": own})
    return dumps


def least_squares(rows, y):
    """Coefficients of y ~ rows (normal equations, Gauss-Jordan; three unknowns)."""
    n = len(rows[0])
    a = [[sum(r[i] * r[j] for r in rows) for j in range(n)] + [sum(r[i] * v for r, v in zip(rows, y))]
         for i in range(n)]
    for i in range(n):
        p = max(range(i, n), key=lambda k: abs(a[k][i]))
        a[i], a[p] = a[p], a[i]
        for k in range(n):
            if k != i:
                f = a[k][i] / a[i][i]
                a[k] = [x - f * z for x, z in zip(a[k], a[i])]
    return [a[i][n] / a[i][i] for i in range(n)]


def print_function_split(dumps, by_total, count):
    """Own instructions per function (M per step) in the p50 band and the p99 band, side by side."""
    n = len(by_total)
    bands = {"p50 band": by_total[int(0.45 * n): int(0.55 * n) + 1], "p99 band": by_total[n - max(1, n // 50):]}
    mean = {}
    for label, steps in bands.items():
        sums = {}
        for k in steps:
            for f, v in dumps[k]["own"].items():
                sums[f] = sums.get(f, 0) + v
        mean[label] = {f: v / len(steps) for f, v in sums.items()}
    totals = {label: sum(m.values()) for label, m in mean.items()}
    print("own instructions per step (M), " + ", ".join(f"{l} {t / 1e6:.3f}" for l, t in totals.items()) + ":")
    top = sorted(mean["p99 band"], key=lambda f: -max(m.get(f, 0) for m in mean.values()))[:count]
    for f in top:
        print("  " + "  ".join(f"{m.get(f, 0) / 1e6:7.3f}" for m in mean.values()) + f"  {f[:110]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("prefix", help="callgrind output prefix (cg.out for cg.out.1, cg.out.2, ...)")
    ap.add_argument("steps_csv", help="steps.csv of a `pliant run` of the same scene")
    ap.add_argument("--first", type=int, default=300, help="first step (0-based) of the window")
    ap.add_argument("--last", type=int, default=899, help="last step of the window")
    ap.add_argument("--functions", type=int, default=0,
                    help="also print the N functions with the most own instructions, averaged over the "
                         "steps ranked 45-55%% (the p50 band) and over the slowest 2%% (the p99 band)")
    args = ap.parse_args()

    steps = list(csv.DictReader(open(args.steps_csv)))
    dumps = read_dumps(args.prefix, args.last + 1)
    window = range(args.first, args.last + 1)
    cg = {k: int(steps[k]["solver_iterations"]) for k in window}
    colliding = {k: int(steps[k]["colliding_vertices"]) for k in window}
    rows = {k: sum(v for f, v in dumps[k]["own"].items() if f.startswith("pliant::sum_stiffness_row")) for k in window}
    total = {k: dumps[k]["total"] for k in window}

    ordered = sorted(total.values())
    rank = lambda p: ordered[min(len(ordered) - 1, max(0, -(-int(p * len(ordered) * 1000) // 1000) - 1))]
    print(f"steps {args.first}-{args.last}: instructions per step p50 {rank(0.5) / 1e6:.3f} M, "
          f"p99 {rank(0.99) / 1e6:.3f} M, min {ordered[0] / 1e6:.3f} M, max {ordered[-1] / 1e6:.3f} M")

    x = [[1.0, cg[k], rows[k]] for k in window]
    y = [total[k] for k in window]
    a, b, c = least_squares(x, y)
    fit = [a + b * r[1] + c * r[2] for r in x]
    mean = statistics.mean(y)
    r2 = 1 - sum((v - f) ** 2 for v, f in zip(y, fit)) / sum((v - mean) ** 2 for v in y)
    print(f"fit: {a / 1e6:.3f} M + {b / 1e6:.3f} M per CG iteration + {c:.2f} x K' row-sum instructions "
          f"(row sums p50 {statistics.median(rows.values()) / 1e6:.2f} M); R^2 {r2:.3f}")

    top = sorted(window, key=lambda k: -total[k])[: max(1, len(window) // 50)]
    print("slowest 2% by instructions (step: M instructions, CG iterations, K' row sums M, colliding):")
    for k in top:
        print(f"  {k}: {total[k] / 1e6:.2f}, {cg[k]}, {rows[k] / 1e6:.2f}, {colliding[k]}")
    print("CG iterations -> steps:", {i: list(cg.values()).count(i) for i in sorted(set(cg.values()))})
    if args.functions > 0:
        print_function_split(dumps, sorted(window, key=lambda k: total[k]), args.functions)
    print("steps that called malloc (step: calls):",
          {k: dumps[k]["mallocs"] for k in window if dumps[k]["mallocs"] > 0} or "none")


if __name__ == "__main__":
    main()
