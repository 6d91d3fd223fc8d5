#!/usr/bin/env python3
"""Compare builds' step times on one scene by interleaved rounds (a developer's tool, not a test).

On a shared VM the host's speed drifts by 15-35% between minutes (docs/bench.md), so two builds
timed one after the other compare the minutes, not the code. This runs `pliant bench SCENE` for
every build in turn, ROUNDS times over (build A, build B, A, B, ...), each round with both clocks
unless told otherwise, and prints per build and clock the median over the rounds of each column of
the bench's table, and the range of the step's p99 over the rounds. It also reads the host's steal
time from /proc/stat before and after (a VM's host taking the CPU shows there).

  scripts/interleaved_bench.py SCENE LABEL=BUILD_DIR[@THREADS] [LABEL=BUILD_DIR[@THREADS] ...]
      [--rounds 5] [--steps 600] [--warm-up 300] [--clock cpu|wall|both] [--json OUT]

e.g. scripts/interleaved_bench.py assets/scenes/probe.json main=build mine=/work/wt/x/build
     scripts/interleaved_bench.py assets/scenes/probe.json t1=build@1 t2=build@2 --clock wall
@THREADS runs that build with `--threads THREADS` (the scene's own "threads" otherwise); thread CPU
time counts the calling thread only, so compare thread counts by the wall clock.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

COLUMNS = ["step_ms_p50", "step_ms_p99", "integrate_ms_p50", "detect_ms_p50", "depth_ms_p50",
           "respond_ms_p50", "report_ms_p50"]
HEADINGS = ["step50", "step99", "integrate", "detect", "depth", "respond", "report"]


def steal_jiffies():
    """The host's steal time (USER_HZ ticks, all CPUs), or None where /proc/stat does not say."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
        return int(fields[8]) if fields[0] == "cpu" and len(fields) > 8 else None
    except OSError:
        return None


def run_bench(pliant, threads, scene, args, clock, out_json):
    cmd = [pliant, "bench", scene, "--steps", str(args.steps), "--warm-up", str(args.warm_up),
           "--no-variants", "--json", out_json]
    if threads is not None:
        cmd += ["--threads", str(threads)]
    if clock == "cpu":
        cmd.append("--cpu-time")
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"interleaved_bench.py: {' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
    with open(out_json) as f:
        rows = json.load(f)["rows"]
    if len(rows) != 1 or rows[0].get("fault"):
        sys.exit(f"interleaved_bench.py: {' '.join(cmd)}: expected one row without a fault, got {rows}")
    return rows[0]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scene")
    parser.add_argument("builds", nargs="+",
                        help="LABEL=BUILD_DIR[@THREADS] (BUILD_DIR/apps/pliant is run, with --threads THREADS if given)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--warm-up", type=int, default=300)
    parser.add_argument("--clock", choices=["cpu", "wall", "both"], default="both")
    parser.add_argument("--json", help="write every round's rows and the medians here")
    args = parser.parse_args()
    if args.rounds < 1 or args.steps < 1 or args.warm_up < 0:
        sys.exit("interleaved_bench.py: --rounds and --steps must be >= 1, --warm-up >= 0")
    if not os.path.isfile(args.scene):
        sys.exit(f"interleaved_bench.py: {args.scene}: no such scene file")

    builds = []
    for spec in args.builds:
        label, sep, build = spec.partition("=")
        build, at, threads = build.partition("@")
        pliant = os.path.join(build, "apps", "pliant")
        if not sep or not label or not os.access(pliant, os.X_OK) or (at and not threads.isdigit()):
            sys.exit(f"interleaved_bench.py: '{spec}': expected LABEL=BUILD_DIR[@THREADS] with an executable"
                     " BUILD_DIR/apps/pliant and THREADS a positive whole number")
        if at and int(threads) < 1:
            sys.exit(f"interleaved_bench.py: '{spec}': THREADS must be >= 1")
        builds.append((label, pliant, int(threads) if at else None))
    clocks = ["cpu", "wall"] if args.clock == "both" else [args.clock]

    rounds = {(label, clock): [] for label, _, _ in builds for clock in clocks}
    steal_before = steal_jiffies()
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        out_json = os.path.join(tmp, "bench.json")
        for _ in range(args.rounds):
            for label, pliant, threads in builds:
                for clock in clocks:
                    rounds[(label, clock)].append(run_bench(pliant, threads, args.scene, args, clock, out_json))
    steal_after = steal_jiffies()
    load_after = os.getloadavg()[0]

    print(f"{args.scene}: {args.rounds} interleaved rounds, {args.steps} steps after {args.warm_up}; "
          f"load {load_before:.2f} -> {load_after:.2f}; host steal "
          + (f"{(steal_after - steal_before) * 1000 // os.sysconf('SC_CLK_TCK')} ms"
             if steal_before is not None and steal_after is not None else "unknown"))
    print(f"{'build':<12} {'clock':<5} " + " ".join(f"{h:>9}" for h in HEADINGS)
          + "   step99 range  (ms; medians over the rounds)")
    medians = {}
    for (label, clock), rows in rounds.items():
        med = {c: statistics.median(r[c] for r in rows) for c in COLUMNS}
        p99 = [r["step_ms_p99"] for r in rows]
        medians[f"{label}/{clock}"] = dict(med, step_ms_p99_min=min(p99), step_ms_p99_max=max(p99))
        print(f"{label:<12} {clock:<5} " + " ".join(f"{med[c]:>9.4f}" for c in COLUMNS)
              + f"   {min(p99):.3f}-{max(p99):.3f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"scene": args.scene, "rounds": args.rounds, "steps": args.steps, "warm_up": args.warm_up,
                       "medians": medians,
                       "runs": {f"{label}/{clock}": rows for (label, clock), rows in rounds.items()}}, f, indent=1)


if __name__ == "__main__":
    main()
