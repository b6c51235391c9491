"""Validated records whose errors read as one clear line per field.

Options, laws and the ``nscd run`` configuration files are pydantic models.  Pydantic's own
message spans several lines per field, names one bound of a range ("Input should be
greater than or equal to 0.5") and ends with a link.  :class:`Checked` models raise
:class:`InputError` (a ``ValueError``) instead, one item per problem, each naming the
field, the value given and the allowed range read from the field's constraints::

    Options: theta = 0.3: must be a number in [0.5, 1]
    ElasticWire: stiffness = 0.0: must be a finite number > 0
    Coulomb: mu_ = 0.3: unknown field (the fields are: mu)

:func:`describe` formats one pydantic error the same way (the CLI lists a file's problems
one per line with it).
"""
from __future__ import annotations

import types
import typing

import annotated_types as at
import numpy as np
from pydantic import BaseModel, ValidationError, field_validator

from .errors import InputError

__all__ = ["Checked", "NumbersOnly", "InputError", "allowed", "describe", "explain"]


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def allowed(cls, name: str) -> str | None:
    """The allowed values of field ``name`` of model ``cls`` in words ("a number in
    [0.5, 1]", "an integer >= 1", "a finite number > 0"), or None without constraints."""
    f = cls.model_fields.get(name)
    if f is None:
        return None
    lo = hi = None
    finite = False
    for m in f.metadata:
        if isinstance(m, at.Ge):
            lo = ("[", m.ge)
        elif isinstance(m, at.Gt):
            lo = ("(", m.gt)
        elif isinstance(m, at.Le):
            hi = ("]", m.le)
        elif isinstance(m, at.Lt):
            hi = (")", m.lt)
        elif getattr(m, "allow_inf_nan", True) is False:
            finite = True
    ann = f.annotation
    args = [a for a in typing.get_args(ann) if a is not type(None)]
    if typing.get_origin(ann) in (typing.Union, types.UnionType) and len(args) == 1:
        ann = args[0]                                     # Optional[float] -> float
    if typing.get_origin(ann) is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in typing.get_args(ann))
    if ann is int:
        kind = "an integer"
    elif ann is float:
        kind = "a finite number" if finite and (lo is None or hi is None) else "a number"
    else:
        kind = "a value"
    if lo is not None and hi is not None:
        return f"{kind} in {lo[0]}{_num(lo[1])}, {_num(hi[1])}{hi[0]}"
    if lo is not None:
        return f"{kind} {'>=' if lo[0] == '[' else '>'} {_num(lo[1])}"
    if hi is not None:
        return f"{kind} {'<=' if hi[0] == ']' else '<'} {_num(hi[1])}"
    return kind if ann is float and finite else None


def _owner(cls, loc):
    """The model class holding the last element of ``loc`` (nested models followed)."""
    for part in loc[:-1]:
        f = cls.model_fields.get(part) if isinstance(part, str) else None
        ann = getattr(f, "annotation", None)
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            cls = ann
        else:
            return None
    return cls


def describe(err: dict, cls, prefix: str = "") -> str:
    """One pydantic error (an item of ``ValidationError.errors()``) of model ``cls`` as
    ``field = value: what is allowed``."""
    loc = tuple(err.get("loc", ()))
    field = prefix + ".".join(str(x) for x in loc)
    typ = err.get("type", "")
    msg = err.get("msg", "")
    owner = _owner(cls, loc) if loc else None
    name = loc[-1] if loc else None
    if typ == "extra_forbidden":
        names = ", ".join(owner.model_fields) if owner is not None else "?"
        return f"{field} = {short_repr(err.get('input'))}: unknown field (the fields are: {names})"
    rng = allowed(owner, name) if owner is not None and isinstance(name, str) else None
    if typ == "missing":
        return f"{field}: required" + (f", {rng}" if rng else "")
    if typ == "value_error":  # a validator's own message, already in words
        text = msg.removeprefix("Value error, ")
        if not loc:  # a check across fields
            return f"{prefix.rstrip('.')}: {text}" if prefix else text
        # "name = value: ..." -> "prefix.loc.name = value: ..."
        return field + text[len(str(name)):] if text.startswith(str(name)) else f"{field}: {text}"
    got = err.get("input")
    what = f"must be {rng}" if rng else msg[:1].lower() + msg[1:]
    return f"{field} = {short_repr(got)}: {what}"


def short_repr(value, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters (a list of 200 000 numbers is not
    printed whole in an error message)."""
    text = repr(value)
    if len(text) <= limit:
        return text
    size = f", {len(value)} items" if hasattr(value, "__len__") else ""
    return f"{text[:limit]}… ({len(text)} characters{size})"


def explain(e: ValidationError, cls, prefix: str = "") -> str:
    """Every error of ``e`` on one line, ``; ``-separated, after the model's name."""
    return f"{cls.__name__}: " + "; ".join(describe(x, cls, prefix) for x in e.errors())


def _numeric(ann) -> bool:
    """Whether annotation ``ann`` is a number, an optional number or a tuple of numbers
    (``Annotated`` metadata unwrapped)."""
    if typing.get_origin(ann) is typing.Annotated:
        return _numeric(typing.get_args(ann)[0])
    if ann in (int, float):
        return True
    args = [a for a in typing.get_args(ann) if a is not type(None) and a is not Ellipsis]
    return bool(args) and typing.get_origin(ann) in (typing.Union, types.UnionType, tuple) \
        and all(_numeric(a) for a in args)


def _boolean(ann) -> bool:
    """Whether annotation ``ann`` is bool or an optional bool."""
    if typing.get_origin(ann) is typing.Annotated:
        return _boolean(typing.get_args(ann)[0])
    if ann is bool:
        return True
    args = [a for a in typing.get_args(ann) if a is not type(None)]
    return typing.get_origin(ann) in (typing.Union, types.UnionType) and args == [bool]


def _not_a_number(v) -> str | None:
    """What ``v`` is when it is a string, a bool or a container of them (the values
    pydantic's lax mode would turn into numbers), or None."""
    if isinstance(v, (str, bytes, np.str_, np.bytes_)):
        return "a string"
    if isinstance(v, (bool, np.bool_)):
        return "a bool"
    if isinstance(v, np.ndarray):
        return {"U": "strings", "S": "strings", "b": "bools"}.get(v.dtype.kind)
    if isinstance(v, (list, tuple)):
        inner = [_not_a_number(x) for x in v]
        return next((("strings" if w == "a string" else "bools" if w == "a bool" else w)
                     for w in inner if w), None)
    return None


class NumbersOnly(BaseModel):
    """A pydantic model whose number fields refuse strings and bools (``dt="1e-5"``,
    ``max_iter=True``), and whose bool fields refuse anything but a bool (``resume="yes"``,
    ``neighbour_contact=1``), which pydantic's lax mode converts: there they are a mistake
    in the caller's code or file.  Numpy's number scalars are numbers, ``numpy.bool_`` a
    bool."""

    @field_validator("*", mode="before")
    @classmethod
    def _numbers_only(cls, v, info):
        ann = cls.model_fields[info.field_name].annotation
        if _boolean(ann) and v is not None and not isinstance(v, (bool, np.bool_)):
            raise ValueError(f"{info.field_name} = {v!r}: must be true or false, not "
                             f"{type(v).__name__}")
        what = _not_a_number(v) if _numeric(ann) else None
        if what:
            rng = allowed(cls, info.field_name) or \
                ("numbers" if typing.get_origin(ann) is tuple else "a number")
            raise ValueError(f"{info.field_name} = {v!r}: must be {rng}, not {what}")
        return v


class Checked(NumbersOnly):
    """A pydantic model raising :class:`InputError` with :func:`explain`'s message, and
    refusing strings and bools for numbers (:class:`NumbersOnly`)."""

    def __init__(self, **data):
        try:
            super().__init__(**data)
        except ValidationError as e:
            raise InputError(explain(e, type(self))) from None
