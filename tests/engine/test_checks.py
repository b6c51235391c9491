"""engine.checks: the allowed values read from a field's constraints, and the one-line
messages built on them (their use on Options and the laws: tests/engine/test_scene.py)."""
from typing import Literal, Optional

import pytest
from pydantic import ConfigDict, Field

from engine.checks import Checked, InputError, allowed


class _Rec(Checked):
    model_config = ConfigDict(extra="forbid")
    a: float = Field(0.5, ge=0.5, le=1.0)
    b: float = Field(1.0, gt=0.0, lt=2.0)
    c: float = Field(1.0, gt=0.0, allow_inf_nan=False)
    d: int = Field(3, ge=1)
    e: Optional[float] = Field(None, ge=0.0)
    f: Literal["x", "y"] = "x"
    g: tuple[float, float] = (0.0, 0.0)
    h: str = "free"
    k: float = Field(0.0, le=3.0)


@pytest.mark.parametrize("name, words", [
    ("a", "a number in [0.5, 1]"),
    ("b", "a number in (0, 2)"),
    ("c", "a finite number > 0"),
    ("d", "an integer >= 1"),
    ("e", "a number >= 0"),                 # Optional[float]: the float's bounds
    ("f", "one of 'x', 'y'"),
    ("g", None),                            # no constraint to state
    ("h", None),
    ("k", "a number <= 3"),
    ("nope", None),                         # not a field
])
def test_allowed_reads_the_constraints(name, words):
    assert allowed(_Rec, name) == words


def test_every_problem_on_one_line():
    with pytest.raises(InputError) as e:
        _Rec(a=0.2, d=0, f="z", zz=1)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("_Rec: ")
    items = msg.removeprefix("_Rec: ").split("; ")
    assert items[0] == "a = 0.2: must be a number in [0.5, 1]"
    assert items[1] == "d = 0: must be an integer >= 1"
    assert items[2] == "f = 'z': must be one of 'x', 'y'"
    assert items[3].startswith("zz = 1: unknown field (the fields are: a, b, c, d, e, f, g, h, k)")
    assert len(items) == 4


def test_strings_are_refused_for_numbers_only():
    with pytest.raises(InputError, match=r"^_Rec: e = '1': must be a number >= 0, not a string$"):
        _Rec(e="1")
    with pytest.raises(InputError, match=r"^_Rec: g = '0, 0': must be numbers, not a string$"):
        _Rec(g="0, 0")
    assert _Rec(h="text", f="y").h == "text"           # a str field takes a string
