"""The slot solver over a long run: per-call time and memory stay flat (no accumulation).

Solves N components drawn from a fixed pool of random small components (facts on the
likelihood grid of 40 levels) with one :class:`~sensemaking.abduction.slots.SlotSolver` and
prints, per block of calls, the mean CPU milliseconds per call, the process's peak RSS and the
size of clasp's problem in the Controls (variables + constraints: grows if anything accumulates).
At the end the last block is timed again, alternating the long-lived solver with a new one (the
machine's load drifts; alternating cancels it), and the pool on fresh Controls for the ratio.

    python benchmarks/slot_solver.py [--calls 100000] [--block 10000] [--pool 2000]
"""

from __future__ import annotations

import argparse
import random
import resource
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=100_000)
    parser.add_argument("--block", type=int, default=10_000)
    parser.add_argument("--pool", type=int, default=2_000)
    args = parser.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_slots import GRID, random_component

    from sensemaking.abduction.slots import SlotSolver
    from sensemaking.abduction.solver import AbductionSolver

    rng = random.Random(0)
    pool = [
        random_component(rng, rng.randint(1, 3), rng.randint(1, 3), rng.randint(0, 1))
        for _ in range(args.pool)
    ]
    solver = AbductionSolver()
    slots = SlotSolver(solver, numbers=GRID + [1], misses_per_cell=0)
    for component in pool:  # ground every shape first
        slots.solve(component)
    done = 0
    slot_ms = []
    while done < args.calls:
        t0 = time.process_time()
        for i in range(done, done + args.block):
            slots.solve(pool[i % len(pool)])
        ms = (time.process_time() - t0) / args.block * 1e3
        slot_ms.append(ms)
        done += args.block
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(
            f"calls {done:7d}  {ms:.3f} ms/call  peak RSS {rss:.0f} MB  clasp size {_size(slots)}",
            flush=True,
        )
    last = [pool[i % len(pool)] for i in range(done - args.block, done)]
    new = SlotSolver(solver, numbers=GRID + [1], misses_per_cell=0)
    for component in pool:
        new.solve(component)
    times = {"long-lived": 0.0, "new": 0.0}
    for _ in range(3):
        for name, which in (("long-lived", slots), ("new", new)):
            t0 = time.process_time()
            for component in last:
                which.solve(component)
            times[name] += (time.process_time() - t0) / (3 * len(last)) * 1e3
    print(
        f"last block again: long-lived {times['long-lived']:.3f}, new {times['new']:.3f} ms/call"
    )
    t0 = time.process_time()
    sample = pool[: min(len(pool), 500)]
    for component in sample:
        solver.solve_facts(component.facts(solver.uses))
    fresh = (time.process_time() - t0) / len(sample) * 1e3
    print(
        f"slots: first block {slot_ms[0]:.3f}, last block {slot_ms[-1]:.3f} ms/call; "
        f"fresh Control {fresh:.3f} ms/call; ratio {slot_ms[-1] / fresh:.2f}; {slots.stats}"
    )
    return 0


def _size(slots) -> int:
    """Variables plus constraints of clasp's problem, summed over the ground shapes."""
    total = 0
    for grounded in slots._grounded.values():
        generator = grounded.ctl.statistics["problem"]["generator"]
        total += int(generator["vars"] + generator["constraints"])
    return total


if __name__ == "__main__":
    sys.exit(main())
