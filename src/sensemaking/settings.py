"""Tracker parameters from users' files and ``--set`` overrides, merged over a preset.

The parameters themselves, with their kind, unit and valid range, are declared once in
:mod:`sensemaking.config` (:data:`~sensemaking.config.PARAMETERS`, read from the fields'
metadata), which also reads the shipped presets and the parameter document format; this module
loads users' files and overrides and merges them in layers (:func:`load_config`). The names it
re-exports from :mod:`sensemaking.config` are kept for its callers. :func:`parse_value` turns
the text of ``--set KEY=VALUE`` into a typed value; presets (``presets/<family>.json``, shipped
with the package) and user parameter files share one format:

.. code-block:: json

    {
      "format": "sensemaking-params/1",
      "base": "kitti",
      "source": "where the values came from (free text)",
      "profile": "driving",
      "params": {"min_hits": 3, "start_confidence": 0.8, "costs": {"resumes": 200},
                 "kalman.velocity_std": 0.1}
    }

``params`` holds values in the units of the table, nested (``{"costs": {"resumes": 200}}``) or
dotted (``"costs.resumes": 200``). ``base`` (optional) names the preset the values change
(``kitti``, ``mot`` or ``defaults``); without it the caller's family applies. A ``.toml`` file
with the same keys (``[params]``, ``[params.costs]``) is read as well. Unknown keys, wrong types
and values out of range are errors naming the file and the key.

``profile`` (optional) is the scene profile of the family's cameras, ``driving`` (a camera on an
ego vehicle: the ego-vehicle situations apply) or ``fixed`` (a standing or handheld camera, no
ego vehicle); the presets name theirs (:func:`preset_profile`: KITTI ``driving``, MOT
``fixed``), ``sensemaking track --profile`` overrides it. Which situations apply to each profile
is stated in ``reasoning/encodings/situations.lp``.
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Iterable, Mapping
from os import PathLike
from pathlib import Path
from typing import Any

from sensemaking.config import (
    CLASS_KEY,
    FAMILIES,
    FORMAT,
    PARAMETERS,
    SCENE_PROFILES,
    Param,
    ParameterError,
    TrackerConfig,
    apply_settings,
    check_value,
    document_params,
    family_name,
    is_class_key,
    parameters_table,
    params_of,
    preset_config,
    preset_params,
    preset_profile,
    preset_source,
    split_class_key,
    suggest,
    validate,
)
from sensemaking.errors import TOO_DEEP
from sensemaking.io.text import load_json, read_input_text

__all__ = [
    "FAMILIES",
    "FORMAT",
    "PARAMETERS",
    "Param",
    "ParameterError",
    "family_name",
    "validate",
    "parse_value",
    "check_value",
    "preset_params",
    "preset_source",
    "preset_profile",
    "SCENE_PROFILES",
    "preset_config",
    "load_params",
    "read_params_file",
    "load_config",
    "apply_settings",
    "params_of",
    "write_params",
    "parameters_table",
]

log = logging.getLogger(__name__)
_SCORE_UNIT = "detector score"


# -- overrides ------------------------------------------------------------------------------
def parse_value(key: str, text: str) -> Any:
    """The typed value of ``--set KEY=TEXT``: ``true``/``false`` (any case) for switches,
    ``null``/``none`` for optional values, ``WxH`` or ``[W, H]`` for sizes, numbers otherwise.
    Raises :class:`ParameterError` (unknown key, wrong type, out of range)."""
    p = PARAMETERS.get(key)
    raw = text.strip()
    if p is None and is_class_key(key):  # class_confidence.CLASS.THRESHOLD: a score
        try:
            number = float(raw)
        except ValueError:
            raise ParameterError(f"{key} must be a number ({_SCORE_UNIT}), got {text!r}") from None
        return check_value(key, number)
    if p is None:
        raise ParameterError(f"unknown parameter {key!r}{suggest(key)}")
    low = raw.lower()
    if p.kind == "classes":  # a whole table, as JSON: {} clears it
        try:
            table = load_json(raw) if low not in ("null", "none") else {}
        except (json.JSONDecodeError, RecursionError):
            raise ParameterError(
                f'{key} must be a JSON table such as {{"pedestrian": {{"min_confidence": 0.5}}}}'
                f", got {text!r}"
            ) from None
        return check_value(key, table)
    if low in ("null", "none") and p.optional:
        return None
    if p.kind == "bool":
        if low in ("true", "yes", "on", "1"):
            return True
        if low in ("false", "no", "off", "0"):
            return False
        raise ParameterError(f"{key} must be true or false, got {text!r}")
    if p.kind == "size":
        m = re.fullmatch(r"\[?\s*(\d+)\s*[x,]\s*(\d+)\s*\]?", low)
        if not m:
            raise ParameterError(f"{key} must look like 1242x375, got {text!r}")
        return check_value(key, (_integer(key, m.group(1)), _integer(key, m.group(2))))
    if p.kind == "int":
        if not re.fullmatch(r"[+-]?\d+", raw):
            raise ParameterError(f"{key} must be an integer ({p.expect()}), got {text!r}")
        return check_value(key, _integer(key, raw))
    try:
        value = float(raw)
    except ValueError:
        raise ParameterError(f"{key} must be a number ({p.expect()}), got {text!r}") from None
    return check_value(key, value)


def _integer(key: str, digits: str) -> int:
    """``int(digits)``; past Python's digit limit a ParameterError, not a bare ValueError."""
    try:
        return int(digits)
    except ValueError:
        raise ParameterError(
            f"{key} must be in {PARAMETERS[key].range_text()}, got a {len(digits)}-digit number"
        ) from None


def read_params_file(path: str | PathLike[str]) -> tuple[dict[str, Any], str | None, str]:
    """(validated dotted params, base family or None, source text) of a parameter file."""
    p = Path(path)
    try:
        text = read_input_text(p)
    except FileNotFoundError:
        raise ParameterError("parameter file not found", p) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterError(f"cannot read parameter file: {exc}", p) from None
    if p.suffix.lower() == ".toml":
        import tomllib

        try:
            doc = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ParameterError(f"not valid TOML: {exc}", p) from None
        except RecursionError:
            raise ParameterError(TOO_DEEP, p) from None
    else:
        try:
            doc = load_json(text)
        except json.JSONDecodeError as exc:
            raise ParameterError(f"not valid JSON: {exc.msg}", p, exc.lineno) from None
        except RecursionError:
            raise ParameterError(TOO_DEEP, p) from None
    params = document_params(doc, str(p))
    base = doc.get("base")
    if base is not None:
        if base == "defaults":
            base = "defaults"
        else:
            try:
                base = family_name(base)
            except ParameterError:
                raise ParameterError(f"base {base!r} is not kitti, mot or defaults", p) from None
    return params, base, str(doc.get("source", ""))


def load_params(path: str | PathLike[str]) -> dict[str, Any]:
    """The validated parameters of a file, as dotted key -> value (the ``base`` not applied)."""
    return read_params_file(path)[0]


def _default_config() -> TrackerConfig:
    return TrackerConfig()


def load_config(
    path: str | PathLike[str] | None,
    family: str | None = None,
    facts: Mapping[str, Any] | None = None,
    overrides: Iterable[str] = (),
) -> TrackerConfig:
    """A ``TrackerConfig`` from layers, each over the one before: the defaults; the preset of the
    file's ``base`` (else of ``family``, if given); the file's values (``path`` None: no file);
    ``facts`` of the input (frame rate, image size, CLI switches; dotted keys); then
    ``overrides`` as ``KEY=VALUE`` texts (``--set``)."""
    params: dict[str, Any] = {}
    base = family
    if path is not None:
        params, file_base, _ = read_params_file(path)
        base = file_base or family
    config = _default_config() if base in (None, "defaults") else preset_config(str(base))
    where = None if path is None else str(path)
    config = apply_settings(config, params, where)
    if facts:
        config = apply_settings(config, facts)
    sets = parse_overrides(overrides)
    if sets:
        try:
            config = apply_settings(config, sets)
        except ParameterError as exc:
            raise ParameterError(f"--set: {exc.problem}") from None
    return config


def parse_overrides(overrides: Iterable[str]) -> dict[str, Any]:
    """``KEY=VALUE`` texts (``--set``) as dotted key -> typed value, each checked against
    :data:`PARAMETERS`. Raises :class:`ParameterError` naming the item."""
    sets: dict[str, Any] = {}
    for item in overrides:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ParameterError(
                f"--set {item!r}: expected KEY=VALUE, e.g. --set costs.resumes=200"
            )
        try:
            sets[key] = parse_value(key, text)
        except ParameterError as exc:
            raise ParameterError(f"--set {exc.problem}") from None
    return sets


def write_params(
    path: str | PathLike[str], params: Mapping[str, Any], source: str, base: str | None = None
) -> Path:
    """Write dotted ``params`` (validated) as a parameter file (JSON, nested), atomically."""
    from sensemaking.io.atomic import atomic_write

    nested: dict[str, Any] = {}
    for key, value in sorted(params.items(), key=lambda kv: (kv[0].count("."), kv[0])):
        value = check_value(key, value)
        if isinstance(value, tuple):
            value = list(value)
        if is_class_key(key):  # class_confidence.CLASS.THRESHOLD -> nested two levels
            cls, threshold = split_class_key(key)
            classes = nested.setdefault(CLASS_KEY, {})
            classes[cls] = {**classes.get(cls, {}), threshold: value}
            continue
        head, _, tail = key.partition(".")
        if tail:
            nested.setdefault(head, {})[tail] = value
        else:
            nested[key] = value
    doc: dict[str, Any] = {"format": FORMAT}
    if base is not None:
        doc["base"] = base if base == "defaults" else family_name(base)
    doc["source"] = source
    doc["params"] = nested
    out = Path(path)
    with atomic_write(out) as fh:
        fh.write(json.dumps(doc, indent=2) + "\n")
    return out
