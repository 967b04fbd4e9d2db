"""Tracker parameters as data: the range table, validation, presets and parameter files.

Every parameter of :class:`~sensemaking.tracker.TrackerConfig` (and of its nested ``costs`` and
``kalman``) has one row in :data:`PARAMETERS`: its kind, unit and valid range.
:func:`validate` checks a configuration against that table (``TrackerConfig.__post_init__`` calls
it); :func:`parse_value` turns the text of ``--set KEY=VALUE`` into a typed value; presets
(``presets/<family>.json``, shipped with the package) and user parameter files share one format:

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
import inspect
import json
import logging
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from importlib import resources
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sensemaking.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.tracker import TrackerConfig

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
_NESTED = ("costs", "kalman")
_FILE_KEYS = {"format", "base", "source", "params", "profile"}
#: scene profiles: a camera on an ego vehicle, or a standing / handheld camera without one
SCENE_PROFILES: tuple[str, ...] = ("driving", "fixed")


class ParameterError(InputError):
    """A parameter value of the wrong type, unit or range, or an unknown parameter."""


@dataclass(frozen=True)
class Param:
    """One parameter: ``kind`` is ``bool``, ``int``, ``float`` or ``size`` (width, height);
    values lie in ``[low, high]`` (``low_open``: ``low`` itself excluded); ``optional``: None
    is allowed (meaning: off / not set)."""

    key: str
    kind: str
    unit: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    optional: bool = False

    def range_text(self) -> str:
        if self.kind == "bool":
            return "true / false"
        if self.kind == "size":
            return f"two integers in [{_num(self.low)}, {_num(self.high)}]"
        low = "(" if self.low_open else "["
        lo = "-inf" if self.low is None else _num(self.low)
        hi = "inf" if self.high is None else _num(self.high)
        text = f"{low}{lo}, {hi}]" if self.high is not None else f"{low}{lo}, inf)"
        if self.kind == "int":
            text = f"integer in {text}"
        elif self.low is None and self.high is None:
            text = "any finite number"
        return text + (", or null" if self.optional else "")


def _num(x: float | None) -> str:
    return "" if x is None else (str(int(x)) if float(x).is_integer() else repr(float(x)))


_SCORE = "detector score"
_COST = "solver units (1000 = a perfect IoU match)"
_BOX = "fraction of box size"


def _table() -> dict[str, Param]:
    rows = [
        Param("abduction", "bool", "-"),
        Param("fps", "float", "frames / s", 0.01, 1000.0),
        Param("image_size", "size", "pixels (width, height)", 1, 100_000, optional=True),
        Param("iou_assign", "float", "IoU", 0.0, 1.0),
        Param("iou_resume", "float", "IoU", 0.0, 1.0),
        Param("resume_growth", "float", "fraction of box size per frame", 0.0, 1.0),
        Param("new_track_growth", "float", "factor", 1.0, 10.0),
        Param("min_confidence", "float", _SCORE),
        Param("start_confidence", "float", _SCORE),
        Param("max_hidden_s", "float", "s", 0.0, 3600.0),
        Param("max_missing_s", "float", "s", 0.0, 3600.0),
        Param("min_hits", "int", "detections", 1, 1000),
        Param("confirm_confidence", "float", _SCORE, optional=True),
        Param("hide_cover", "float", "fraction of box area", 0.0, 1.0),
        Param("emerge_margin", "float", "fraction of occluder size", 0.0, 10.0),
        Param("keep_cover", "float", "fraction of box area (<= hide_cover)", 0.0, 1.0),
        Param("partial_cover", "float", "fraction of box area", 0.0, 1.0),
        Param("border_margin", "float", "pixels", 0.0, 10_000.0),
        Param("class_aware", "bool", "-"),
        Param("inherit_motion", "bool", "-"),
        Param("confidence_sigmoid", "bool", "-"),
        Param("likelihood_levels", "int", "levels", 1, 1000),
        Param("decompose", "bool", "- (null: on for the packaged encoding)", optional=True),
        Param("max_conflicts", "int", "solver conflicts per program", 1, 10**9, optional=True),
        Param("max_solve_ms", "float", "ms", 0.0, 3_600_000.0, low_open=True, optional=True),
        Param(
            "velocity_prior", "float", "box sizes / s", 0.0, 1000.0, low_open=True, optional=True
        ),
        Param("weak_confidence", "float", _SCORE, optional=True),
        Param("weak_iou", "float", "IoU", 0.0, 1.0),
        Param("resume_reupdate", "bool", "-"),
        Param("scene_shift", "bool", "-"),
        Param(
            "unseen_damping",
            "float",
            "fraction of velocity kept per unseen frame",
            0.0,
            1.0,
            low_open=True,
        ),
    ]
    for name in (
        "enters",
        "appears",
        "leaves",
        "lost",
        "dropped",
        "hides",
        "missing",
        "unseen",
        "ignore",
        "resumes",
    ):
        rows.append(Param(f"costs.{name}", "int", _COST, 0, 100_000))
    for name in (
        "position_std",
        "velocity_std",
        "measurement_std",
        "init_position_std",
        "init_velocity_std",
    ):
        unit = _BOX + (" per frame" if name != "measurement_std" else "")
        rows.append(Param(f"kalman.{name}", "float", unit, 0.0, 100.0, low_open=True))
    rows.append(Param("kalman.min_size", "float", "pixels", 0.0, 10_000.0, low_open=True))
    return {p.key: p for p in rows}


#: dotted parameter name -> :class:`Param`
PARAMETERS: dict[str, Param] = _table()


# -- families ------------------------------------------------------------------------------------
def family_name(family: str) -> str:
    """The canonical family (``kitti`` / ``mot``) of a family or benchmark-rules name."""
    key = str(family).strip().lower()
    key = _FAMILY_ALIASES.get(key, key)
    if key not in FAMILIES:
        raise ParameterError(f"unknown dataset family {family!r} (kitti or mot)")
    return key


# -- checking one value -----------------------------------------------------------------------
def _is_int(value: Any) -> bool:
    import numbers

    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_real(value: Any) -> bool:
    import numbers

    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def check_value(key: str, value: Any) -> Any:
    """``value`` if it is valid for parameter ``key`` (sizes become tuples), else
    :class:`ParameterError` saying what is expected."""
    p = PARAMETERS.get(key)
    if p is None:
        raise ParameterError(f"unknown parameter {key!r}{_suggest(key)}")
    if value is None:
        if p.optional:
            return None
        raise ParameterError(f"{key} must not be null ({_expect(p)})")
    if p.kind == "bool":
        if not isinstance(value, bool):
            import numpy as np

            if not isinstance(value, np.bool_):
                raise ParameterError(f"{key} must be true or false, got {value!r}")
        return bool(value)
    if p.kind == "size":
        if (
            not isinstance(value, (tuple, list))
            or len(value) != 2
            or not all(_is_int(v) for v in value)
        ):
            raise ParameterError(f"{key} must be (width, height) in integer pixels, got {value!r}")
        for v in value:
            _check_range(p, v)
        return (int(value[0]), int(value[1]))
    if p.kind == "int":
        if not _is_int(value):
            raise ParameterError(f"{key} must be an integer ({_expect(p)}), got {value!r}")
        _check_range(p, value)
        return value
    if not _is_real(value) or not math.isfinite(float(value)):
        raise ParameterError(f"{key} must be a finite number ({_expect(p)}), got {value!r}")
    _check_range(p, value)
    return value


def _expect(p: Param) -> str:
    return f"{p.unit}, {p.range_text()}" if p.unit != "-" else p.range_text()


def _check_range(p: Param, value: float) -> None:
    v = float(value)
    too_low = p.low is not None and (v <= p.low if p.low_open else v < p.low)
    too_high = p.high is not None and v > p.high
    if too_low or too_high:
        raise ParameterError(f"{p.key} must be in {p.range_text()} ({p.unit}), got {value!r}")


def _suggest(key: str) -> str:
    import difflib

    close = difflib.get_close_matches(key, list(PARAMETERS), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def parse_value(key: str, text: str) -> Any:
    """The typed value of ``--set KEY=TEXT``: ``true``/``false`` (any case) for switches,
    ``null``/``none`` for optional values, ``WxH`` or ``[W, H]`` for sizes, numbers otherwise.
    Raises :class:`ParameterError` (unknown key, wrong type, out of range)."""
    p = PARAMETERS.get(key)
    if p is None:
        raise ParameterError(f"unknown parameter {key!r}{_suggest(key)}")
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
            raise ParameterError(f"{key} must be an integer ({_expect(p)}), got {text!r}")
        return check_value(key, int(raw))
    try:
        value = float(raw)
    except ValueError:
        raise ParameterError(f"{key} must be a number ({_expect(p)}), got {text!r}") from None
    return check_value(key, value)


# -- checking a whole configuration ----------------------------------------------------------
def params_of(config: Any) -> dict[str, Any]:
    """Every parameter of a ``TrackerConfig`` as dotted key -> value."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if f.name in _NESTED and dataclasses.is_dataclass(value):
            for g in dataclasses.fields(value):
                out[f"{f.name}.{g.name}"] = getattr(value, g.name)
        else:
            out[f.name] = value
    return out


def validate(config: Any) -> None:
    """Check every parameter of a ``TrackerConfig`` against :data:`PARAMETERS` and the relations
    between them. Raises :class:`ParameterError` (a ``ValueError``) naming the first bad one.
    Fields the table does not know are left to their own class (a test keeps the table
    complete)."""
    for key, value in params_of(config).items():
        if key in PARAMETERS:
            check_value(key, value)
        else:
            log.debug("parameter %s has no row in settings.PARAMETERS", key)
    if config.keep_cover > config.hide_cover:
        raise ParameterError(
            f"keep_cover ({config.keep_cover}) must not exceed hide_cover ({config.hide_cover})"
        )


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
            raise ParameterError(f"params: unknown parameter {key!r}{_suggest(key)}", where)
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
    from sensemaking.tracker import TrackerConfig

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


# -- documentation ------------------------------------------------------------------------------
def _docstring_meanings(cls: type) -> dict[str, str]:
    """``name: text`` entries of a class docstring's ``Attributes:`` section."""
    doc = inspect.getdoc(cls) or ""
    out: dict[str, str] = {}
    section = doc.split("Attributes:", 1)[1] if "Attributes:" in doc else ""
    current: str | None = None
    for line in section.splitlines():
        m = re.match(r"^    (\w+): (.*)$", line)
        if m:
            current = m.group(1)
            out[current] = m.group(2).strip()
        elif current and line.startswith("        "):
            out[current] += " " + line.strip()
        elif line.strip() == "":
            continue
        else:
            current = None
    return out


def _comment_meanings(cls: type) -> dict[str, str]:
    """``#:`` comments of a dataclass's fields (on the line, or in the lines above)."""
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):  # pragma: no cover - source not shipped
        return {}
    out: dict[str, str] = {}
    above: list[str] = []
    for line in source.splitlines():
        s = line.strip()
        if s.startswith("#:"):
            above.append(s[2:].strip())
            continue
        m = re.match(r"^(\w+): [^=]+=[^#]*(?:#:\s*(.*))?$", s)
        if m:
            text = " ".join(above + ([m.group(2)] if m.group(2) else []))
            out[m.group(1)] = text.strip()
        above = []
    return out


def parameters_table() -> str:
    """The markdown table of every parameter: name, unit, valid range, default, meaning (the
    meaning is read from the docstrings and field comments of the configuration classes)."""
    from sensemaking.tracker import TrackerConfig

    config = TrackerConfig()
    defaults = params_of(config)
    meanings = {k: v for k, v in _docstring_meanings(TrackerConfig).items()}
    nested_cls = {name: type(getattr(config, name)) for name in _NESTED}
    for name, cls in nested_cls.items():
        found = _docstring_meanings(cls) or _comment_meanings(cls)
        if not found or len(found) < len(dataclasses.fields(cls)) // 2:
            found = {**_comment_meanings(cls), **found}
        for k, v in found.items():
            meanings[f"{name}.{k}"] = v
    lines = ["| parameter | unit | valid values | default | meaning |", "|---|---|---|---|---|"]
    for key, p in PARAMETERS.items():
        default = defaults.get(key)
        text = meanings.get(key, "").replace("|", "\\|")
        lines.append(
            f"| `{key}` | {p.unit} | {p.range_text()} | {_fmt_default(default)} | {text} |"
        )
    return "\n".join(lines)


def _fmt_default(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple):
        return "x".join(str(v) for v in value)
    return str(value)
