"""The abduction record's quick check of its facts agrees with clingo's parser."""

from __future__ import annotations

import clingo
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sensemaking.abduction.record import _NAME, _PLAIN_FACT, ProblemRecord
from sensemaking.errors import InputError


def _clingo_atom(text: str) -> bool:
    """What :meth:`ProblemRecord.symbols` accepts: a ground atom named by ``_NAME``."""
    try:
        sym = clingo.parse_term(text, logger=lambda code, msg: None)
    except RuntimeError:
        return False
    return sym.type == clingo.SymbolType.Function and bool(_NAME.fullmatch(sym.name))


# pieces of terms, the tracker's and the troublesome: keywords, variables, odd numbers, blanks
_pieces = st.sampled_from(
    ["cand", "d", "not", "note", "x_1", "_x", "X", "_", "inf", "0", "7", "-3", "01", "-0",
     "1234567890", "(", ")", ",", " ", '"s"', "#sup", "a'", ".", "f("]
)  # fmt: skip


@settings(max_examples=3000, deadline=None)
@given(st.lists(_pieces, min_size=1, max_size=9).map("".join))
def test_what_the_quick_check_accepts_clingo_parses_as_an_atom(text: str) -> None:
    if _PLAIN_FACT.fullmatch(text):
        assert _clingo_atom(text), text


@pytest.mark.parametrize(
    "text",
    ["cand(2,d(2),600)", "holds(visibility(0),partially_occluded,0)", "det_border(d(0))",
     "track(-5)", "halted(12)", "note(1)"],
)  # fmt: skip
def test_the_tracker_facts_pass_the_quick_check(text: str) -> None:
    assert _PLAIN_FACT.fullmatch(text) and _clingo_atom(text)


@pytest.mark.parametrize("fact", ["cand(1,", "X(1)", '"text"', "3", "f(01)"])
def test_check_raises_as_symbols_does(fact: str) -> None:
    problem = ProblemRecord(4, (1,), 1, (), ("track(0)", fact))
    with pytest.raises(InputError) as checked:
        problem.check("s.json")
    with pytest.raises(InputError) as parsed:
        problem.symbols("s.json")
    assert str(checked.value) == str(parsed.value) and "fact 1" in str(checked.value)


def test_facts_beyond_the_quick_check_are_left_to_clingo() -> None:
    # nested deeper than the tracker writes, a long number, a name with a leading underscore
    facts = ("f(a(b(c)))", "n(1234567890)", "_x(1)")
    assert not any(_PLAIN_FACT.fullmatch(f) for f in facts)
    problem = ProblemRecord(4, (1,), 1, (), facts)
    problem.check("s.json")  # accepted, as symbols() accepts them
    assert [str(s) for s in problem.symbols("s.json")] == list(facts)
