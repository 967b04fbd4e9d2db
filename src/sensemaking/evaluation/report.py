"""Results: :class:`SequenceMetrics` (one sequence, or COMBINED), :class:`Report` (a benchmark)."""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sensemaking.evaluation.metrics import (
    ALPHAS,
    CLEAR_FIELDS,
    COUNT_FIELDS,
    HOTA_ARRAY_FIELDS,
    IDENTITY_FIELDS,
    combine_clear,
    combine_count,
    combine_hota,
    combine_identity,
)

__all__ = [
    "SequenceMetrics",
    "Report",
    "COMBINED",
    "SCALAR_FIELDS",
    "TABLE_FIELDS",
    "INTEGER_FIELDS",
    "PER_SEQUENCE_FIELDS",
]

#: key of the combined result among the sequences of a :class:`Report`
COMBINED = "COMBINED"
#: the fields a per-sequence summary keeps (benchmark runs, fleet archives); the combined
#: metrics keep every field
PER_SEQUENCE_FIELDS = (
    "HOTA",
    "DetA",
    "AssA",
    "MOTA",
    "MOTP",
    "IDF1",
    "IDSW",
    "Frag",
    "MT",
    "PT",
    "ML",
    "CLR_TP",
    "CLR_FP",
    "CLR_FN",
    "GT_IDs",
    "IDs",
)
_HOTA_SCALAR_ARRAYS = tuple(
    f for f in HOTA_ARRAY_FIELDS if f not in ("HOTA_TP", "HOTA_FN", "HOTA_FP")
)
#: every scalar field, in report order (per-alpha HOTA fields give their mean over alpha)
SCALAR_FIELDS = (
    _HOTA_SCALAR_ARRAYS
    + ("HOTA(0)", "LocA(0)", "HOTALocA(0)")
    + CLEAR_FIELDS
    + IDENTITY_FIELDS
    + COUNT_FIELDS
)
#: fields that count things (printed as integers, never as percentages)
INTEGER_FIELDS = frozenset(
    (
        "CLR_TP",
        "CLR_FN",
        "CLR_FP",
        "IDSW",
        "MT",
        "PT",
        "ML",
        "Frag",
        "CLR_Frames",
        "IDTP",
        "IDFN",
        "IDFP",
    )
    + COUNT_FIELDS
)
#: fields that are not fractions although they are floats
_PLAIN_FLOATS = frozenset(("MOTP_sum", "FP_per_frame"))
#: default columns of :meth:`Report.table`
TABLE_FIELDS = (
    "HOTA",
    "DetA",
    "AssA",
    "LocA",
    "MOTA",
    "MOTP",
    "IDF1",
    "IDR",
    "IDP",
    "CLR_Re",
    "CLR_Pr",
    "IDSW",
    "Frag",
    "CLR_FP",
    "CLR_FN",
    "MT",
    "PT",
    "ML",
    "Dets",
    "GT_Dets",
    "IDs",
    "GT_IDs",
)


@dataclass(frozen=True, eq=False)
class SequenceMetrics(Mapping[str, float]):
    """Metrics of one sequence (or several combined): a read-only mapping field -> value.

    Values use TrackEval's field names; fractions are in [0, 1], counts are ints. Per-alpha HOTA
    fields (HOTA, DetA, AssA, DetRe, DetPr, AssRe, AssPr, LocA, OWTA) map to their mean over the
    19 alphas; the arrays themselves are in :attr:`per_alpha` (with HOTA_TP/FN/FP), alphas in
    :data:`~sensemaking.evaluation.metrics.ALPHAS`.

    Attributes:
        name: sequence name, or ``"COMBINED"``.
        class_name: the scored class (``"pedestrian"``, ``"car"``).
        idsw_mode: ``"trackeval"`` or ``"kitti_legacy"``.
        parts: raw per-family results (``clear``, ``identity``, ``hota``, ``count``), used to
            combine.
    """

    name: str
    class_name: str
    idsw_mode: str
    parts: Mapping[str, Mapping[str, Any]] = field(repr=False)

    def _value(self, key: str) -> float:
        for part in self.parts.values():
            if key in part:
                v = part[key]
                if isinstance(v, np.ndarray):
                    return float(np.mean(v))
                return int(v) if key in INTEGER_FIELDS else float(v)
        raise KeyError(key)

    def __getitem__(self, key: str) -> float:
        if key not in SCALAR_FIELDS:
            raise KeyError(key)
        return self._value(key)

    def __iter__(self) -> Iterator[str]:
        return iter(SCALAR_FIELDS)

    def __len__(self) -> int:
        return len(SCALAR_FIELDS)

    @property
    def per_alpha(self) -> dict[str, np.ndarray]:
        """Per-alpha HOTA arrays, each (19,), for alpha = 0.05 .. 0.95."""
        return {
            f: np.asarray(self.parts["hota"][f], dtype=float).copy() for f in HOTA_ARRAY_FIELDS
        }

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict: every scalar field plus ``per_alpha`` lists."""
        out: dict[str, Any] = {k: self[k] for k in SCALAR_FIELDS}
        out["per_alpha"] = {k: [float(x) for x in v] for k, v in self.per_alpha.items()}
        return out

    @classmethod
    def combine(cls, items: Sequence[SequenceMetrics], name: str = COMBINED) -> SequenceMetrics:
        """Combine sequences as TrackEval does: counts summed, ratios recomputed (HOTA per alpha,
        association and localisation weighted by each sequence's true positives)."""
        if not items:
            raise ValueError("nothing to combine")
        modes = {m.idsw_mode for m in items}
        classes = {m.class_name for m in items}
        if len(modes) > 1 or len(classes) > 1:
            raise ValueError("cannot combine metrics of different classes or ID-switch modes")
        parts = {
            "clear": combine_clear([m.parts["clear"] for m in items]),
            "identity": combine_identity([m.parts["identity"] for m in items]),
            "hota": combine_hota([m.parts["hota"] for m in items]),
            "count": combine_count([m.parts["count"] for m in items]),
        }
        return cls(
            name=name, class_name=items[0].class_name, idsw_mode=items[0].idsw_mode, parts=parts
        )

    def __repr__(self) -> str:
        return (
            f"SequenceMetrics({self.name!r}, {self.class_name}, HOTA={self['HOTA']:.4f}, "
            f"MOTA={self['MOTA']:.4f}, IDF1={self['IDF1']:.4f}, idsw_mode={self.idsw_mode!r})"
        )


def _fmt(field_name: str, value: float) -> str:
    if field_name in INTEGER_FIELDS:
        return str(int(value))
    if field_name in _PLAIN_FLOATS:
        return f"{value:.2f}"
    return f"{100.0 * value:.3f}"


@dataclass(frozen=True, eq=False)
class Report:
    """Results of a benchmark: per class, per sequence plus ``"COMBINED"``.

    Attributes:
        benchmark: ``"mot17"``, ``"mot15"``, ``"kitti"``, ...
        idsw_mode: ``"trackeval"`` or ``"kitti_legacy"``; every number in the report uses it.
        results: class name -> (sequence name or ``"COMBINED"``) -> :class:`SequenceMetrics`.
        threshold: IoU threshold of CLEAR and Identity matches.
    """

    benchmark: str
    idsw_mode: str
    results: Mapping[str, Mapping[str, SequenceMetrics]]
    threshold: float = 0.5

    @property
    def classes(self) -> list[str]:
        return list(self.results)

    @property
    def sequences(self) -> list[str]:
        """Sequence names (without COMBINED), in evaluation order."""
        first = next(iter(self.results.values()), {})
        return [s for s in first if s != COMBINED]

    def combined(self, class_name: str | None = None) -> SequenceMetrics:
        """The COMBINED metrics of a class (the only class when None)."""
        return self._class(class_name)[COMBINED]

    def _class(self, class_name: str | None) -> Mapping[str, SequenceMetrics]:
        if class_name is None:
            if len(self.results) != 1:
                raise KeyError(f"report has classes {self.classes}: name one")
            return next(iter(self.results.values()))
        return self.results[class_name]

    def __getitem__(self, sequence: str) -> SequenceMetrics:
        """Metrics of a sequence (or ``"COMBINED"``) for a single-class report."""
        return self._class(None)[sequence]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (fractions in [0, 1], counts as ints)."""
        return {
            "format": "sensemaking-evaluation/1",
            "benchmark": self.benchmark,
            "idsw_mode": self.idsw_mode,
            "threshold": self.threshold,
            "fractions": "in [0, 1]",
            "alphas": [round(float(a), 2) for a in ALPHAS],
            "classes": {
                cls: {
                    "sequences": {s: m.to_dict() for s, m in res.items() if s != COMBINED},
                    "combined": res[COMBINED].to_dict(),
                }
                for cls, res in self.results.items()
            },
        }

    def to_json(self, indent: int | None = 2) -> str:
        """The report as JSON text (see :meth:`to_dict`)."""
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    def table(self, fields: Sequence[str] = TABLE_FIELDS) -> str:
        """Fixed-width text table, one block per class; fractions printed as percentages."""
        unknown = [f for f in fields if f not in SCALAR_FIELDS]
        if unknown:
            raise KeyError(f"unknown fields {unknown}")
        lines: list[str] = []
        for cls, res in self.results.items():
            names = list(res)
            w0 = max([len("sequence")] + [len(n) for n in names])
            widths = [max(len(f), 8) for f in fields]
            if lines:
                lines.append("")
            lines.append(
                f"{self.benchmark} / {cls}  (idsw_mode: {self.idsw_mode}; "
                f"percentages except counts; IoU threshold {self.threshold:g})"
            )
            lines.append(
                "  ".join(
                    ["sequence".ljust(w0)]
                    + [f.rjust(w) for f, w in zip(fields, widths, strict=True)]
                )
            )
            ordered = [n for n in names if n != COMBINED] + [COMBINED]
            for n in ordered:
                if n == COMBINED:
                    lines.append("-" * len(lines[-1]))
                m = res[n]
                lines.append(
                    "  ".join(
                        [n.ljust(w0)]
                        + [_fmt(f, m[f]).rjust(w) for f, w in zip(fields, widths, strict=True)]
                    )
                )
        return "\n".join(lines) + "\n"
