"""Issue 24's numbered cases, one test (or more) each: the trust boundary of every verb
(docs/SECURITY.md). Each failed on the main branch before the sandbox module, the locked-down
query connection and the write-through outputs."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from sensemaking.cli import main

from test_hostile import one_line_error, scene_file, write_det  # noqa: F401 (fixture)


# 2. a query that does not parse is refused before clingo sees it ----------------------------------
@pytest.mark.parametrize(
    "query",
    [
        'q("abc\n). #include "secret.lp". #show secret/1.',
        'q("\\#include "secret.lp". ").',
        'q(1). %* a comment *% #include "secret.lp".',
    ],
)
def test_a_hidden_include_is_refused_before_clingo_opens_the_file(
    scene_file: Path, capsys, monkeypatch, query: str
) -> None:
    (scene_file.parent / "secret.lp").write_text("secret(42).\n")
    monkeypatch.chdir(scene_file.parent)
    assert main(["ask", "--timeout", "5", str(scene_file), query]) == 2
    line = one_line_error(capsys)
    assert "#include is not allowed" in line and "42" not in line


def test_a_query_that_does_not_parse_is_refused_with_its_position(scene_file: Path, capsys) -> None:
    assert main(["ask", str(scene_file), 'q("abc\n).']) == 2
    line = one_line_error(capsys)
    assert "invalid query: query:1:" in line
