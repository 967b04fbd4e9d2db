"""The clingo symbols of Python fact tuples: made once, the same symbols as clingo's."""

from __future__ import annotations

import clingo
import pytest

from sensemaking import asp
from sensemaking.reasoning.facts import AspString, fact_symbol, symbol


def test_symbols_are_clingos_own() -> None:
    fact = ("holds", ("", 3, "car"), AspString("lane 1"), -7, ("f",))
    assert symbol(fact) == clingo.parse_term('holds((3,car),"lane 1",-7,f)')


def test_a_string_and_a_constant_of_the_same_text_stay_apart() -> None:
    assert symbol("a").type == clingo.SymbolType.Function
    assert symbol(AspString("a")).type == clingo.SymbolType.String
    assert symbol("a").type == clingo.SymbolType.Function  # the cache did not mix them


@pytest.mark.parametrize("term", [True, 1.5, None, [1]])
def test_no_symbol_for_other_python_values(term: object) -> None:
    with pytest.raises(TypeError):
        symbol(term)


def test_the_cache_of_made_symbols_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(asp, "_TERMS_KEPT", 50)
    monkeypatch.setattr(asp, "_TERMS", {})
    for n in range(1000):
        assert symbol(n).number == n
        assert asp.term(("p", n, ("d", n))) == clingo.Function(
            "p", [clingo.Number(n), clingo.Function("d", [clingo.Number(n)])]
        )
    assert 0 < len(asp._TERMS) <= 50


def test_a_facts_symbol_is_its_symbol_and_made_once() -> None:
    cache: dict = {}
    fact = ("position", 3, 17, 1234, -56)
    assert fact_symbol(fact, cache) == clingo.parse_term("position(3,17,1234,-56)")
    assert fact_symbol(("position", 3, 17, 1234, -56), cache) is cache[fact]


def test_a_fact_with_a_string_never_takes_the_constants_symbol() -> None:
    cache: dict = {}
    assert str(fact_symbol(("lane", "l1"), cache)) == "lane(l1)"
    assert str(fact_symbol(("lane", AspString("l1")), cache)) == 'lane("l1")'
    assert str(fact_symbol(("occurs_at", ("hides", 1, 2), 0), cache)) == "occurs_at(hides(1,2),0)"
    assert list(cache) == [("lane", "l1")]  # a string or a nested term is made each time


def test_the_cache_of_fact_symbols_is_bounded() -> None:
    cache: dict = {}
    for n in range(1000):
        assert fact_symbol(("state", n, 0, "visible"), cache, kept=50).arguments[0].number == n
    assert 0 < len(cache) <= 50
