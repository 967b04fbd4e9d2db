"""A frame's abduction, component by component, with clingo's answers remembered.

Two shortcuts, both forced by the structure of the problem rather than by any rule:

* **Independent components** are solved separately (:meth:`FrameProblem.components` gives the
  argument: no rule of ``tracking.lp`` joins atoms of two components and the objective is a sum).
  Off for encodings not known to be local (``decompose=False``): the frame is one program.
* **A component solved before** is answered from a cache of clingo's own answers, keyed by
  its canonical facts (:class:`~sensemaking.abduction.problem.Component`): the same facts, in
  the same order, given to the same program and options, give the same answer. Answers cut short
  by the wall-clock budget are not remembered (they depend on machine load); answers cut short
  by the deterministic conflict budget are (they do not). The cache is shared by every solver
  of the process with the same program and options (the answers are the same).

A component missing from the cache is solved by clingo: if it is small, by a Control ground once
for its shape (:class:`~sensemaking.abduction.slots.SlotSolver`: an optimal answer of the same
cost, ties possibly broken otherwise), else on a fresh Control.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Iterable

from sensemaking.abduction.problem import Component, FrameProblem
from sensemaking.abduction.slots import SlotSolver
from sensemaking.abduction.solver import AbductionSolver, Answer

__all__ = ["ComponentSolver"]

#: per (program, options): clingo's answers by component, least recently used first
_CACHES: dict[tuple[str, tuple[str, ...]], OrderedDict[Component, Answer]] = {}
#: per (program, options): the Controls ground once for small components
_SLOTS: dict[tuple[str, tuple[str, ...]], SlotSolver] = {}
_LOCK = threading.Lock()


class ComponentSolver:
    """Solves frames component by component through an LRU cache of clingo's answers.

    Args:
        solver: the clingo solver (program, constants, options).
        decompose: solve independent components separately (True) or the frame as one
            program (False; for encodings whose rules may relate unconnected objects).
        cache_size: components remembered per program (least recently used first out); 0
            disables the cache. Memory stays bounded on runs of any length.
        slots: answer small components missing from the cache with Controls ground once
            (:class:`~sensemaking.abduction.slots.SlotSolver`) instead of a fresh Control.
        numbers: the likelihoods and confidences (0..1000) the facts take, e.g. the tracker's
            likelihood grid: ground into the slots up front (others are learnt as they come).
    """

    def __init__(self, solver: AbductionSolver, decompose: bool = True, cache_size: int = 50_000,
                 slots: bool = True, numbers: Iterable[int] = ()):
        self.solver = solver
        self.decompose = decompose
        self.cache_size = cache_size
        key = (solver.program, tuple(solver.options))
        with _LOCK:
            self._cache = _CACHES.setdefault(key, OrderedDict())
            self._slots = _SLOTS.setdefault(key, SlotSolver(solver)) if slots else None
            if self._slots is not None:
                self._slots.expect(numbers)
        self.stats = {"components": 0, "cache_hits": 0, "solver_calls": 0, "slot_calls": 0}

    def solve(self, problem: FrameProblem, budget_ms: float | None = None) -> Answer | None:
        """The frame's answer in its terms (track ids, detection rows); None if some component
        got no model within the budgets (the caller falls back for the whole frame)."""
        t0 = time.perf_counter()
        parts = problem.components() if self.decompose else [problem.whole()]
        answer = Answer()
        for component, track_ids, det_rows in parts:
            with _LOCK:
                local = self._cache.get(component)
                if local is not None:
                    self._cache.move_to_end(component)
            if local is not None:
                self.stats["cache_hits"] += 1
            else:
                remaining = None if budget_ms is None else budget_ms - (time.perf_counter() - t0) * 1e3
                local = None if self._slots is None else self._slots.solve(component, remaining)
                if local is not None:
                    self.stats["slot_calls"] += 1
                else:
                    local = self.solver.solve_facts(component.facts(self.solver.uses), remaining)
                    self.stats["solver_calls"] += 1
                if local is None:
                    return None
                if not local.timed_out and self.cache_size > 0:
                    with _LOCK:
                        self._cache[component] = local
                        while len(self._cache) > self.cache_size:
                            self._cache.popitem(last=False)
            self.stats["components"] += 1
            answer.merge(local.mapped(track_ids, det_rows))
        answer.solve_ms = (time.perf_counter() - t0) * 1e3
        return answer
