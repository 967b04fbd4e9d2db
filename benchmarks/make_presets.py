"""Write the shipped presets from a benchmark run's cross-validation, reproducibly.

    sensemaking benchmark --trackers ours,ours-noabd --json out/bench.json
    python benchmarks/make_presets.py --json out/bench.json

For each family the run cross-validated (``crossval`` in the JSON): if rule *calibrate* is as
good as the grid by the rule stated before measuring (``crossval.calibrate_verdict``), the
values ``sensemaking calibrate`` estimates become its estimates on every video of the family,
every benchmark pooled; otherwise the grid's parameters become the recommended set (the grid
point most folds chose) and calibrate's estimates are left out. Every other value of the preset
stays as it is and the ``source`` says so. The file keeps its key order and layout (one
parameter per line), so that a value changed is a line changed.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

PRESETS = Path(__file__).resolve().parents[1] / "src" / "sensemaking" / "presets"
#: what each family's sequences are (the first sentence of the source)
DATA = {
    "kitti": "KITTI tracking training 0000-0010 (RRC and PointRCNN detections, car and "
    "pedestrian), 10 fps from a moving car.",
    "mot": "MOTChallenge: MOT17 half-val YOLOX (02, 04, 05, 09), MOT17-05 public FRCNN, 2D MOT "
    "2015 train (6 sequences).",
}


def dump(doc: dict[str, Any]) -> str:
    """The preset layout: top-level keys and parameters one per line, nested tables inline."""
    lines = ["{"]
    items = list(doc.items())
    for i, (key, value) in enumerate(items):
        comma = "," if i < len(items) - 1 else ""
        if key == "params":
            lines.append('  "params": {')
            params = list(value.items())
            for j, (k, v) in enumerate(params):
                end = "," if j < len(params) - 1 else ""
                lines.append(f"    {json.dumps(k)}: {json.dumps(v)}{end}")
            lines.append("  }" + comma)
        else:
            lines.append(f"  {json.dumps(key)}: {json.dumps(value)}{comma}")
    lines.append("}")
    return "\n".join(lines) + "\n"


def set_value(params: dict[str, Any], key: str, value: Any) -> None:
    """Set a dotted key in the nested params (new keys appended)."""
    head, _, tail = key.partition(".")
    if tail:
        params.setdefault(head, {})[tail] = value
    else:
        params[key] = value


def flat_keys(params: dict[str, Any]) -> list[str]:
    out = []
    for k, v in params.items():
        if isinstance(v, dict):
            out += [f"{k}.{sub}" for sub in v]
        else:
            out.append(k)
    return out


def preset_from_run(family: str, cv: dict[str, Any], run: dict[str, Any], doc: dict[str, Any]):
    """(new preset document, one line saying what changed) from one family's cross-validation."""
    from sensemaking.calibrate import ESTIMATED

    verdict = cv.get("calibrate_verdict") or {}
    params = json.loads(json.dumps(doc["params"]))  # a deep copy, key order kept
    how = (
        f"in the run of {run.get('started', '?')} (`{run.get('command', '')}`, docs/PARAMETERS.md)"
    )
    folds = len(cv["folds"])
    if verdict.get("as_good"):
        chosen = dict(cv["calibrated_all"])
        origin = (
            f"{', '.join(chosen)}: estimated by `sensemaking calibrate` on every video of the "
            "family, every benchmark pooled; cross-validated as good as the grid "
            f"({100 * verdict['mean_calibrate']:.2f} against {100 * verdict['mean_grid']:.2f} "
            f"mean HOTA, not worse on {verdict['folds_not_worse']} of {folds} folds) {how}."
        )
        keys = list(ESTIMATED)
    else:
        counts: dict[int, int] = {}
        for i in cv["choice"].values():
            counts[i] = counts.get(i, 0) + 1
        chosen = dict(cv["points"][cv["recommended"]])
        origin = (
            f"{', '.join(chosen)}: the grid point {counts.get(cv['recommended'], 0)} of {folds} "
            f"leave-one-video-out folds chose {how}."
        )
        if verdict:
            origin += (
                " `sensemaking calibrate`'s estimates (every benchmark of the family pooled) "
                f"cross-validated worse ({100 * verdict['mean_calibrate']:.2f} against "
                f"{100 * verdict['mean_grid']:.2f} mean HOTA, not worse on "
                f"{verdict['folds_not_worse']} of {folds} folds) and are not used."
            )
        keys = list(chosen)
    for key in keys:
        if key in chosen:
            set_value(params, key, chosen[key])
    kept = [k for k in flat_keys(params) if k not in chosen]
    source = (
        f"{DATA[family]} {origin} Kept from the earlier preset, chosen by hand on the same "
        f"sequences (in-sample) or facts of the data: {', '.join(kept)}; docs/PARAMETERS.md "
        "says where each value comes from. Written by benchmarks/make_presets.py."
    )
    new = {**doc, "source": source, "params": params}
    return new, f"{family}: " + ", ".join(f"{k}={v}" for k, v in chosen.items())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", required=True, type=Path, help="the benchmark run's JSON")
    ap.add_argument("--presets", type=Path, default=PRESETS, help="folder of <family>.json")
    args = ap.parse_args(argv)
    from sensemaking import settings

    run = json.loads(args.json.read_text(encoding="utf-8"))
    if not run.get("crossval"):
        print(f"{args.json}: no cross-validation in this run", file=sys.stderr)
        return 2
    for cv in run["crossval"]:
        family = settings.family_name(cv["family"])
        path = args.presets / f"{family}.json"
        doc = json.loads(path.read_text(encoding="utf-8"))
        new, line = preset_from_run(family, cv, run, doc)
        text = dump(new)
        settings.document_params(json.loads(text), str(path))  # every value valid
        path.write_text(text, encoding="utf-8")
        print(f"{path}: {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
