"""Tracking evaluation: CLEAR MOT, Identity (IDF1), HOTA and Count, with TrackEval's rules.

A small numpy reimplementation of TrackEval (checked against it to 1e-6 in the integration
tests) with the MOTChallenge and KITTI dataset rules, plus the old KITTI devkit's ID-switch rule
as an option::

    from sensemaking.evaluation import evaluate_sequence, evaluate, load_mot_benchmark

    m = evaluate_sequence(gt, tracks, "mot17")          # SequenceMetrics: field -> value
    m["HOTA"], m["MOTA"], m["IDF1"], m.per_alpha["HOTA"]

    report = evaluate(load_mot_benchmark("data/mot17", "runs/mot17"), "mot17")
    print(report.table()); report.to_json()

Fractions are in [0, 1] (TrackEval's convention); tables print percentages. Every report says
which ID-switch rule it used (``idsw_mode``).
"""

from __future__ import annotations

from sensemaking.evaluation.core import SequenceInput, evaluate, evaluate_sequence
from sensemaking.evaluation.loaders import load_kitti_benchmark, load_mot_benchmark, read_seqmap
from sensemaking.evaluation.metrics import ALPHAS, IDSW_MODES
from sensemaking.evaluation.report import (
    COMBINED,
    PER_SEQUENCE_FIELDS,
    Report,
    SequenceMetrics,
)
from sensemaking.evaluation.rules import DatasetRules, get_rules, rules_for_benchmark

__all__ = [
    "ALPHAS",
    "COMBINED",
    "IDSW_MODES",
    "PER_SEQUENCE_FIELDS",
    "DatasetRules",
    "Report",
    "SequenceInput",
    "SequenceMetrics",
    "evaluate",
    "evaluate_sequence",
    "get_rules",
    "load_kitti_benchmark",
    "load_mot_benchmark",
    "read_seqmap",
    "rules_for_benchmark",
]
