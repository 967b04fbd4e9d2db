"""Tracker parameters from files: presets, parameter files and ``--set`` overrides.

The parameters themselves, with their kind, unit and valid range, are declared once in
:mod:`sensemaking.config` (:data:`~sensemaking.config.PARAMETERS`, read from the fields'
metadata); this module loads and merges values over them (the names it re-exports from there
are kept for its callers). :func:`parse_value` turns the text of ``--set KEY=VALUE`` into a
typed value; presets (``presets/<family>.json``, shipped with the package) and user parameter
files share one format:

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

import dataclasses
import json
import logging
import re
from collections.abc import Iterable, Mapping
from importlib import resources
from os import PathLike
from pathlib import Path
from typing import Any

from sensemaking.config import (
    NESTED,
    PARAMETERS,
    Param,
    ParameterError,
    TrackerConfig,
    check_value,
    parameters_table,
    params_of,
    suggest,
    validate,
)

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

#: the dataset families with a shipped preset (``presets/<family>.json``)
FAMILIES: tuple[str, ...] = ("kitti", "mot")
#: other names accepted for a family
_FAMILY_ALIASES = {
    "mot17": "mot",
    "mot15": "mot",
    "mot16": "mot",
    "mot20": "mot",
    "motchallenge": "mot",
}
#: the ``format`` tag of parameter files this version reads and writes
FORMAT = "sensemaking-params/1"
_NESTED = NESTED
_FILE_KEYS = {"format", "base", "source", "params", "profile"}
#: scene profiles: a camera on an ego vehicle, or a standing / handheld camera without one
SCENE_PROFILES: tuple[str, ...] = ("driving", "fixed")


# -- families ------------------------------------------------------------------------------------
def family_name(family: str) -> str:
    """The canonical family (``kitti`` / ``mot``) of a family or benchmark-rules name."""
    key = str(family).strip().lower()
    key = _FAMILY_ALIASES.get(key, key)
    if key not in FAMILIES:
        raise ParameterError(f"unknown dataset family {family!r} (kitti or mot)")
    return key


# -- overrides ------------------------------------------------------------------------------
def parse_value(key: str, text: str) -> Any:
    """The typed value of ``--set KEY=TEXT``: ``true``/``false`` (any case) for switches,
    ``null``/``none`` for optional values, ``WxH`` or ``[W, H]`` for sizes, numbers otherwise.
    Raises :class:`ParameterError` (unknown key, wrong type, out of range)."""
    p = PARAMETERS.get(key)
    if p is None:
        raise ParameterError(f"unknown parameter {key!r}{suggest(key)}")
    raw = text.strip()
    low = raw.lower()
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
        return check_value(key, (int(m.group(1)), int(m.group(2))))
    if p.kind == "int":
        if not re.fullmatch(r"[+-]?\d+", raw):
            raise ParameterError(f"{key} must be an integer ({p.expect()}), got {text!r}")
        return check_value(key, int(raw))
    try:
        value = float(raw)
    except ValueError:
        raise ParameterError(f"{key} must be a number ({p.expect()}), got {text!r}") from None
    return check_value(key, value)


# -- presets and files -----------------------------------------------------------------------
def _preset_document(family: str) -> dict[str, Any]:
    name = family_name(family)
    ref = resources.files("sensemaking") / "presets" / f"{name}.json"
    return json.loads(ref.read_text(encoding="utf-8"))


def preset_params(family: str) -> dict[str, Any]:
    """The shipped preset of a family as dotted key -> value (only the values it changes)."""
    name = family_name(family)
    doc = _preset_document(name)
    return _document_params(doc, f"presets/{name}.json")


def preset_source(family: str) -> str:
    """Where a preset's values came from (its ``source`` text)."""
    return str(_preset_document(family).get("source", ""))


def preset_profile(family: str) -> str:
    """The scene profile a family's preset names (``driving`` when it names none)."""
    return str(_preset_document(family).get("profile", "driving"))


def _flatten(params: Mapping[str, Any], where: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in params.items():
        if key in _NESTED and isinstance(value, Mapping):
            for sub, v in value.items():
                out[f"{key}.{sub}"] = v
        else:
            out[str(key)] = value
    return out


def _document_params(doc: Any, where: str) -> dict[str, Any]:
    """Validated dotted params of a parameter document (``where`` names it in errors)."""
    if not isinstance(doc, Mapping):
        raise ParameterError("a parameter file must hold an object with a 'params' table", where)
    unknown = sorted(set(doc) - _FILE_KEYS)
    if unknown:
        raise ParameterError(
            f"unknown key {unknown[0]!r} (expected {', '.join(sorted(_FILE_KEYS))})", where
        )
    fmt = doc.get("format", FORMAT)
    if fmt != FORMAT:
        raise ParameterError(f"format {fmt!r} is not {FORMAT!r}", where)
    profile = doc.get("profile", SCENE_PROFILES[0])
    if profile not in SCENE_PROFILES:
        raise ParameterError(
            f"profile {profile!r} is not one of {', '.join(SCENE_PROFILES)}", where
        )
    params = doc.get("params", {})
    if not isinstance(params, Mapping):
        raise ParameterError("'params' must be a table of parameter: value", where)
    out: dict[str, Any] = {}
    for key, value in _flatten(params, where).items():
        if key in _NESTED:
            raise ParameterError(
                f"{key}: expected a table of {key}.NAME values, got {value!r}", where
            )
        if key not in PARAMETERS:
            raise ParameterError(f"params: unknown parameter {key!r}{suggest(key)}", where)
        if isinstance(value, list) and key in PARAMETERS and PARAMETERS[key].kind == "size":
            value = tuple(value)
        try:
            out[key] = check_value(key, value)
        except ParameterError as exc:
            raise ParameterError(f"params.{exc.problem}", where) from None
    return out


def read_params_file(path: str | PathLike[str]) -> tuple[dict[str, Any], str | None, str]:
    """(validated dotted params, base family or None, source text) of a parameter file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
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
    else:
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ParameterError(f"not valid JSON: {exc.msg}", p, exc.lineno) from None
    params = _document_params(doc, str(p))
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


def apply_settings(
    config: TrackerConfig, params: Mapping[str, Any], where: str | None = None
) -> TrackerConfig:
    """``config`` with dotted ``params`` applied (``costs.x`` / ``kalman.x`` reach the nested
    settings), validated as a whole."""
    top: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {}
    for key, value in params.items():
        try:
            value = check_value(key, value)
        except ParameterError as exc:
            raise ParameterError(exc.problem, where) from None
        head, _, tail = key.partition(".")
        if tail:
            nested.setdefault(head, {})[tail] = value
        else:
            top[key] = value
    for head, changes in nested.items():
        top[head] = dataclasses.replace(getattr(config, head), **changes)
    try:
        return dataclasses.replace(config, **top)
    except ParameterError as exc:
        raise ParameterError(exc.problem, where) from None
    except (TypeError, ValueError) as exc:
        raise ParameterError(str(exc), where) from None


def _default_config() -> TrackerConfig:
    return TrackerConfig()


def preset_config(family: str, **changes: Any) -> TrackerConfig:
    """The family's preset (``presets/<family>.json``) over the defaults, then ``changes``
    (keyword names; ``costs`` / ``kalman`` as objects, as ``TrackerConfig`` takes them)."""
    config = apply_settings(
        _default_config(), preset_params(family), f"presets/{family_name(family)}.json"
    )
    return dataclasses.replace(config, **changes) if changes else config


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
