"""Fuzz every input-reading verb in-process (``sensemaking.cli.main``): random bytes, truncated and
mutated real files. Each case must exit 0 (or 1 where the verb means "no" by it) or 2, with a
one-line error and no traceback, leave no output file on error and its input unchanged.

Input classes: (a) random bytes, (b) a real file truncated at a random byte, (c) a real file
with 1-8 mutations (byte flips, deleted / duplicated / swapped lines, numbers replaced by nan,
inf, -1, 0, 1e308, 1e9, empty, text, separators added or removed), and for scene JSON half of
(c) as valid JSON with values replaced, deleted or duplicated anywhere in the tree (NaN, 1e300,
huge ints, wrong types, a billion-frame range ...). Real files: a MOT det.txt, a
KITTI RRC and a PointRCNN detection file, MOT gt / results, a KITTI label file, a scene JSON and
a seqinfo.ini, all small and made in the test (no ../shared needed). At least 10,000 cases.
"""

from __future__ import annotations

import json
import random
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sensemaking.cli import main

SEED = 20261125
_TOKENS = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e308",
    "1e9",
    "1000000000",
    "",
    "x",
    "1.5",
    "-0",
    "NaN",
    ",",
    ",,",
    " ",
    "\t",
    '"',
    "{",
    "}",
    "[",
    "]",
    "null",
    "true",
    "1e-320",
    "99999999999999999999",
]
_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One to eight random mutations of ``data``."""
    out = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        kind = rng.randrange(6)
        if kind == 0 and out:  # flip a byte
            out[rng.randrange(len(out))] = rng.randrange(256)
        elif kind == 1:  # a number -> a token
            nums = list(_NUMBER.finditer(bytes(out)))
            if nums:
                m = rng.choice(nums)
                out[m.start() : m.end()] = rng.choice(_TOKENS).encode()
        elif kind == 2:  # delete or duplicate a line
            lines = bytes(out).split(b"\n")
            i = rng.randrange(len(lines))
            if rng.random() < 0.5:
                del lines[i]
            else:
                lines.insert(i, lines[i])
            out = bytearray(b"\n".join(lines))
        elif kind == 3:  # swap two lines
            lines = bytes(out).split(b"\n")
            i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
            out = bytearray(b"\n".join(lines))
        elif kind == 4 and out:  # insert a token
            i = rng.randrange(len(out))
            out[i:i] = rng.choice(_TOKENS).encode()
        elif out:  # delete a run of bytes
            i = rng.randrange(len(out))
            del out[i : i + rng.randint(1, 20)]
    return bytes(out)


_JSON_VALUES = [
    float("nan"),
    float("inf"),
    1e300,
    -1,
    0,
    10**12,
    2**70,
    -(2**70),
    "x",
    "",
    None,
    True,
    [],
    {},
    [1, 1_000_000_000],
    [[1, 2, 3, 4]],
    [0, -5],
    1.5,
    "visible",
    "hidden_by",
]


def mutate_json(data: bytes, rng: random.Random) -> bytes:
    """Valid JSON with one to four values replaced, deleted or duplicated (deep into the scene)."""
    record = json.loads(data)
    for _ in range(rng.randint(1, 4)):
        node: Any = record
        path: list[Any] = []
        while isinstance(node, (dict, list)) and node and (not path or rng.random() < 0.8):
            key = rng.choice(list(node)) if isinstance(node, dict) else rng.randrange(len(node))
            path.append((node, key))
            node = node[key]
        if not path:
            break
        parent, key = path[-1]
        r = rng.random()
        if r < 0.7:
            parent[key] = rng.choice(_JSON_VALUES)
        elif r < 0.85:
            del parent[key]
        elif isinstance(parent, list):
            parent.insert(key, parent[key])
    return json.dumps(record).encode()


def corpus(rng: random.Random, real: bytes, n: int) -> list[bytes]:
    """``n`` inputs: a third random bytes, a third truncated, a third mutated (JSON files: half
    of those mutated as JSON, so that they parse and reach the validation)."""
    out = []
    for k in range(n):
        cls = k % 3
        if cls == 0:
            size = rng.choice([0, 1, 2, 8, 64, 512])
            out.append(
                bytes(rng.randrange(256) for _ in range(size))
                if rng.random() < 0.5
                else bytes(rng.choice(b"0123456789,.-e \n") for _ in range(size))
            )
        elif cls == 1:
            out.append(real[: rng.randrange(len(real) + 1)])
        elif real.startswith(b"{") and rng.random() < 0.5:
            out.append(mutate_json(real, rng))
        else:
            out.append(mutate(real, rng))
    return out


def real_files(tmp: Path) -> dict[str, bytes]:
    from sensemaking.demo import run_demo

    det = "".join(
        f"{f},-1,{100 + 3 * f + (i * 60)},{100 + 5 * i},40,80,0.{9 - i},-1,-1,-1\n"
        for f in range(1, 13)
        for i in range(2)
    )
    rrc = "".join(
        f"{f},{100 + 3 * f + i * 80},{100},{150 + 3 * f + i * 80},{180},0.9{i}\n"
        for f in range(0, 12)
        for i in range(2)
    )
    prcnn = "".join(
        f"{f},2,{100 + 3 * f},100,{150 + 3 * f},180,3.5,1.5,1.6,3.9,1.0,1.5,20.0,0.1,-1.5\n"
        for f in range(0, 10)
    )
    gt = "".join(f"{f},1,{100 + 3 * f},100,40,80,1,1,1.0\n" for f in range(1, 11))
    res = "".join(f"{f},1,{101 + 3 * f},100,40,80,0.9,-1,-1,-1\n" for f in range(1, 11))
    label = "".join(
        f"{f} 1 Car 0 0 -1.5 {100 + 3 * f} 100 {150 + 3 * f} 180 1.5 1.6 3.9 1.0 1.5 20.0 0.1\n"
        for f in range(0, 10)
    )
    scene = run_demo(tmp / "demo", render=False).files["scene"].read_bytes()
    seqinfo = b"[Sequence]\nname=X\nframeRate=10\nseqLength=12\nimWidth=640\nimHeight=480\n"
    return {
        "det": det.encode(),
        "rrc": rrc.encode(),
        "prcnn": prcnn.encode(),
        "gt": gt.encode(),
        "res": res.encode(),
        "label": label.encode(),
        "scene": scene,
        "seqinfo": seqinfo,
    }


@pytest.fixture(scope="module")
def reals(tmp_path_factory) -> dict[str, bytes]:
    return real_files(tmp_path_factory.mktemp("real"))


#: verb -> (cases, real file fuzzed, the argument list given the fuzzed input and an output dir)
def _track_mot(inp: Path, out: Path) -> list[str]:
    return [
        "track",
        "--detections",
        str(inp),
        "--format",
        "mot",
        "--fps",
        "10",
        "--image-size",
        "640x480",
        "--output",
        str(out / "o.txt"),
        "--events",
        str(out / "e.jsonl"),
    ]


def _track_rrc(inp: Path, out: Path) -> list[str]:
    return [
        "track",
        "--detections",
        str(inp),
        "--format",
        "kitti",
        "--class",
        "car",
        "--image-size",
        "640x480",
        "--output",
        str(out / "o.txt"),
        "--scene",
        str(out / "s.json"),
    ]


def _track_prcnn(inp: Path, out: Path) -> list[str]:
    return [
        "track",
        "--detections",
        str(inp),
        "--format",
        "kitti",
        "--image-size",
        "640x480",
        "--output",
        str(out / "o.txt"),
        "--warnings",
        str(out / "w.jsonl"),
    ]


def _track_label(inp: Path, out: Path) -> list[str]:
    return [
        "track",
        "--detections",
        str(inp),
        "--format",
        "kitti",
        "--image-size",
        "640x480",
        "--output",
        str(out / "o.txt"),
    ]


def _track_seqinfo(inp: Path, out: Path, det: Path) -> list[str]:
    return [
        "track",
        "--detections",
        str(det),
        "--format",
        "mot",
        "--seqinfo",
        str(inp),
        "--output",
        str(out / "o.txt"),
    ]


def _evaluate_gt(inp: Path, out: Path, res: Path) -> list[str]:
    return [
        "evaluate",
        "--gt",
        str(inp),
        "--results",
        str(res),
        "--format",
        "mot",
        "--json",
        str(out / "m.json"),
    ]


def _evaluate_res(inp: Path, out: Path, gt: Path) -> list[str]:
    return [
        "evaluate",
        "--gt",
        str(gt),
        "--results",
        str(inp),
        "--format",
        "mot",
        "--json",
        str(out / "m.json"),
    ]


def _explain(inp: Path, out: Path) -> list[str]:
    return ["explain", str(inp), "--json"]


def _ask(inp: Path, out: Path) -> list[str]:
    return ["ask", str(inp), "tracks"]


def _ask_hidden(inp: Path, out: Path) -> list[str]:
    return ["ask", str(inp), "hidden"]


def _report(inp: Path, out: Path) -> list[str]:
    return ["report", str(inp), "-o", str(out / "r.html"), "--thumbnails", "0", "--no-warnings"]


def _render(inp: Path, out: Path) -> list[str]:
    return [
        "render",
        str(inp),
        "-o",
        str(out / "r.gif"),
        "--frames",
        "0:1",
        "--no-warnings",
        "--scale",
        "0.1",
    ]


PLANS = [  # (name, real file, cases, argv builder, extra real file passed to the builder)
    ("track-mot", "det", 2200, _track_mot, None),
    ("track-rrc", "rrc", 1200, _track_rrc, None),
    ("track-pointrcnn", "prcnn", 800, _track_prcnn, None),
    ("track-label", "label", 800, _track_label, None),
    ("track-seqinfo", "seqinfo", 600, _track_seqinfo, "det"),
    ("evaluate-gt", "gt", 800, _evaluate_gt, "res"),
    ("evaluate-results", "res", 800, _evaluate_res, "gt"),
    ("explain", "scene", 1400, _explain, None),
    ("ask", "scene", 900, _ask, None),
    ("ask-hidden", "scene", 300, _ask_hidden, None),
    ("report", "scene", 150, _report, None),
    ("render", "scene", 150, _render, None),
]
#: verbs whose exit status 1 is an answer ("no"), not a failure
_ONE_IS_AN_ANSWER = {"explain", "ask", "ask-hidden"}


@pytest.mark.slow
def test_fuzz_every_verb(tmp_path: Path, reals: dict[str, bytes], capsys) -> None:
    pytest.importorskip("PIL")  # render / report need the viz extra
    rng = random.Random(SEED)
    total = 0
    failures: list[str] = []
    for name, real_key, n, build, extra_key in PLANS:
        work = tmp_path / name
        work.mkdir()
        extra = None
        if extra_key is not None:
            extra = work / f"extra-{extra_key}.txt"
            extra.write_bytes(reals[extra_key])
        for k, data in enumerate(corpus(rng, reals[real_key], n)):
            inp = work / (
                "in.json"
                if real_key == "scene"
                else "seqinfo.ini"
                if real_key == "seqinfo"
                else "in.txt"
            )
            inp.write_bytes(data)
            out = work / "out"
            out.mkdir(exist_ok=True)
            argv = build(inp, out) if extra is None else build(inp, out, extra)
            capsys.readouterr()
            try:
                code = main(["-q"] + argv)
            except SystemExit as exc:  # argparse
                code = exc.code
            captured = capsys.readouterr()
            total += 1
            allowed = {0, 2} | ({1} if name in _ONE_IS_AN_ANSWER else set())
            err_lines = [x for x in captured.err.splitlines() if x.strip()]
            problem = None
            if code not in allowed:
                problem = f"exit {code}"
            elif "Traceback" in captured.err:
                problem = "traceback"
            elif code == 2 and len(err_lines) != 1:
                problem = f"{len(err_lines)} error lines"
            elif code == 2 and list(out.iterdir()):
                problem = f"left {[p.name for p in out.iterdir()]}"
            elif inp.read_bytes() != data:
                problem = "input changed"
            elif list(work.glob("*.part")) or list(out.glob("*.part")):
                problem = "a .part file left"
            if problem is not None:
                failures.append(
                    f"{name} case {k}: {problem}: {captured.err.strip()[:300]!r} "
                    f"input {data[:120]!r}"
                )
            for p in out.iterdir():
                p.unlink() if p.is_file() else None
    assert total >= 10_000
    assert not failures, f"{len(failures)} of {total} cases failed:\n" + "\n".join(failures[:15])


def test_the_corpus_covers_its_classes(reals: dict[str, bytes]) -> None:
    cases = corpus(random.Random(SEED), reals["det"], 300)
    truncated = [c for c in cases[1::3] if reals["det"].startswith(c)]
    assert len(truncated) == 100 and len({len(c) for c in truncated}) > 50
    assert sum(c != reals["det"] for c in cases[2::3]) >= 95
    assert np.mean([len(c) for c in cases[0::3]]) > 10


# -- the trust boundary (issue 24): query SQL, user encodings, manifests, archives ----------------
_SQL = [
    b"SELECT situation, count(*) FROM warnings GROUP BY ALL",
    b"SELECT * FROM tracks WHERE frame < 5 ORDER BY frame, track_id",
    b"SELECT * FROM read_csv('/etc/passwd', header=false, sep=':')",
    b"COPY (SELECT * FROM tracks) TO 'x.csv'",
]
_RULES = b"occurs(stops(T)) :- track(T), speed(T,S), S < 5.\n#show occurs/1.\n"
_SITUATIONS = b"warn(stopped_ahead,(T,)) :- track(T), not track(T+1000).\n"
_MANIFEST = (
    "path,format,class,fps,width,height,frames,gt,rules\n"
    "{det},mot,pedestrian,10,1000,500,30,{gt},mot17\n"
)


def _one_line_or_answer(code: Any, err: str, allowed: set[int]) -> str | None:
    lines = [x for x in err.splitlines() if x.strip()]
    if code not in allowed:
        return f"exit {code}"
    if "Traceback" in err or "internal error" in err:
        return "traceback"
    if code == 2 and len(lines) != 1:
        return f"{len(lines)} error lines"
    return None


@pytest.mark.slow
def test_fuzz_the_trust_boundary(tmp_path: Path, reals: dict[str, bytes], capsys) -> None:
    """``query`` SQL, ``--rules`` / ``--encoding`` / ``--situations`` text, batch manifests and
    damaged archives: every case exits 0 or 2 with one line, writes nothing outside its output
    folder and leaves the archive as it was."""
    pytest.importorskip("duckdb")
    import shutil

    from test_trust_boundary import make_archive

    from sensemaking.errors import InputError
    from sensemaking.fleet.specs import find_sequences, read_manifest

    rng = random.Random(SEED + 24)
    failures: list[str] = []
    total = 0
    archive = make_archive(tmp_path / "archive")
    snapshot = {p: p.read_bytes() for p in archive.rglob("*.parquet")}
    cwd_files = set(Path.cwd().iterdir())

    def check(name: str, k: int, code: Any, err: str, data: bytes, allowed=frozenset({0, 2})):
        nonlocal total
        total += 1
        problem = _one_line_or_answer(code, err, set(allowed))
        if problem is not None:
            failures.append(
                f"{name} case {k}: {problem}: {err.strip()[:300]!r} input {data[:120]!r}"
            )

    # (1) query: mutated and random SQL over the archive
    for k in range(600):
        data = corpus(rng, rng.choice(_SQL), 1)[0] if k % 3 else rng.choice(_SQL)
        sql = data.decode("utf-8", "replace").replace("\x00", " ")
        capsys.readouterr()
        code = main(["-q", "query", str(archive), "--max-rows", "1000", sql])
        check("query", k, code, capsys.readouterr().err, data)
    assert {p: p.read_bytes() for p in archive.rglob("*.parquet")} == snapshot

    # (2) user encodings: mutated rules, encodings and situations
    det = tmp_path / "det.txt"
    det.write_bytes(reals["det"])
    work = tmp_path / "enc"
    work.mkdir()
    for option, real, n in (
        ("--rules", _RULES, 90),
        ("--encoding", _RULES, 30),
        ("--situations", _SITUATIONS, 60),
    ):
        for k, data in enumerate(corpus(rng, real, n)):
            lp = work / "user.lp"
            lp.write_bytes(data)
            out = work / "out"
            out.mkdir(exist_ok=True)
            argv = [
                "-q",
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                "--output",
                str(out / "t.txt"),
                option,
                str(lp),
                "--timeout",
                "10",
                "--max-memory",
                "500",
                "--max-atoms",
                "200000",
            ]
            if option == "--situations":
                argv += ["--warnings", str(out / "w.jsonl")]
            capsys.readouterr()
            code = main(argv)
            err = capsys.readouterr().err
            check(option, k, code, err, data)
            if code == 2 and list(out.iterdir()):
                failures.append(f"{option} case {k}: left {[p.name for p in out.iterdir()]}")
            for p in out.iterdir():
                p.unlink()

    # (3) batch manifests: read as batch reads them
    gt = tmp_path / "gt.txt"
    gt.write_bytes(reals["gt"])
    real = _MANIFEST.format(det=det, gt=gt).encode()
    for k, data in enumerate(corpus(rng, real, 400)):
        m = tmp_path / "manifest.csv"
        m.write_bytes(data)
        total += 1
        try:
            read_manifest(m)
            find_sequences([m])
        except InputError:
            pass
        except Exception as exc:  # noqa: BLE001 - the failure being looked for
            failures.append(f"manifest case {k}: {type(exc).__name__}: {exc} input {data[:120]!r}")

    # (4) damaged archives: one file of a copy truncated, mutated or replaced
    files = sorted(p for p in archive.rglob("*") if p.is_file() and p.name != ".lock")
    for k in range(150):
        copy = tmp_path / "arc-copy"
        shutil.rmtree(copy, ignore_errors=True)
        shutil.copytree(archive, copy)
        victim = copy / rng.choice(files).relative_to(archive)
        raw = victim.read_bytes()
        if victim.suffix == ".json" and rng.random() < 0.5:
            data = mutate_json(raw, rng)
        else:
            data = corpus(rng, raw, 3)[k % 3]
        victim.write_bytes(data)
        capsys.readouterr()
        code = main(["-q", "query", str(copy), "SELECT count(*) FROM tracks"])
        check(f"archive {victim.name}", k, code, capsys.readouterr().err, data)

    assert set(Path.cwd().iterdir()) == cwd_files  # nothing written where the tests run
    assert total >= 1_300
    assert not failures, f"{len(failures)} of {total} cases failed:\n" + "\n".join(failures[:15])
