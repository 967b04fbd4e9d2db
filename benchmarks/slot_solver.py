"""The slot solver over a long run: per-call time and memory stay flat (no accumulation).

Solves N components drawn from a fixed pool of random small components (facts on the
likelihood grid of 40 levels) with one :class:`~sensemaking.abduction.slots.SlotSolver` and
prints, per block of calls, the mean CPU milliseconds per call and the process's peak RSS; then
the same pool on fresh Controls for the ratio, measured in this run.

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
    pool = [random_component(rng, rng.randint(1, 3), rng.randint(1, 3), rng.randint(0, 1))
            for _ in range(args.pool)]
    solver = AbductionSolver()
    slots = SlotSolver(solver, numbers=GRID + [1], ground_after=1)
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
        print(f"calls {done:7d}  {ms:.3f} ms/call  peak RSS {rss:.0f} MB", flush=True)
    t0 = time.process_time()
    sample = pool[: min(len(pool), 500)]
    for component in sample:
        solver.solve_facts(component.facts(solver.uses))
    fresh = (time.process_time() - t0) / len(sample) * 1e3
    print(f"slots: first block {slot_ms[0]:.3f}, last block {slot_ms[-1]:.3f} ms/call; "
          f"fresh Control {fresh:.3f} ms/call; ratio {slot_ms[-1] / fresh:.2f}; {slots.stats}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
