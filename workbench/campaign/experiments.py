"""The paper's tests as campaign experiments: JSON-able parameters in, the test result's
scalars out (:meth:`engine.experiments.TestResult.scalars` and its kind).

``wire = "elastic" | "rigid" | "elastic_rod" | "rigid_rod" | "brittle" | "loose" | "none"`` with ``k``
[N], ``prestrain`` and ``max_tension`` stand for the law object, which is not JSON-able.
"""
from __future__ import annotations

import inspect
import json
import os
from types import MappingProxyType
from typing import Callable, Mapping

from .cases import case_id

__all__ = ["EXPERIMENTS", "CaseInterrupted", "not_interrupted", "scalars_of", "resolve",
           "check_paper_cases"]


class CaseInterrupted(KeyboardInterrupt):
    """A case's run was stopped by Ctrl-C / SIGTERM: it is not a result (its steps were
    not all run) nor a failure to retry; the sweep stops, keeps the cases finished, and
    runs this one again when it is run again."""


def not_interrupted(result, name: str, params: dict):
    """``result`` (an experiment's), or :class:`CaseInterrupted` when Ctrl-C / SIGTERM stopped
    its run: what a sweep's experiment wrapper checks before turning a result into table
    values, so a partial run is never recorded as done."""
    c = getattr(result, "convergence", None) or {}
    if c.get("interrupted"):
        raise CaseInterrupted(f"{name} {json.dumps(params, default=str)}: interrupted after "
                              f"{c.get('steps', 0)} steps (history "
                              f"{getattr(result, 'history', None)})")
    return result


def scalars_of(result) -> dict:
    """The scalar results of an :mod:`engine.experiments` result: ``result.scalars()``
    (each result type says which are its scalars)."""
    return result.scalars()


def _law(wire, k, prestrain=None, max_tension=None):
    """(has a wire, its law) of a sweep case: ``wire`` a law's name
    (:data:`engine.laws.WIRE_LAWS`, or "none"; True and False for "elastic" and "none"),
    ``k`` its stiffness [N], and the law's ``prestrain`` and ``max_tension``
    (:func:`engine.experiments.config.wire_spec`)."""
    from engine.experiments.config import wire_spec

    law = wire_spec(wire, k, prestrain, max_tension).to_law()
    return law is not None, law


def _history_path(params, fixed, default_name):
    d = fixed.get("history_dir") or os.path.join("out", "sweep")
    os.makedirs(d, exist_ok=True)
    return os.path.join(d, f"{case_id(default_name, params)}.h5")


def _paper_test(name):
    def experiment(*, wire="elastic", k=None, prestrain=None, max_tension=None,
                   history_dir=None, **params):
        from engine import experiments

        fn = getattr(experiments, name)
        has_wire, law = _law(wire, k, prestrain, max_tension)
        kw = dict(params)
        kw["wire"] = has_wire
        if params.get("sample") is not None and wire == "elastic" and k is None \
                and prestrain is None and max_tension is None:
            law = None                 # a start state's wire keeps its own law
        if has_wire and law is not None:
            kw["wire_law"] = law
        key_params = dict(params, wire=wire, k=k)     # (ids of earlier tables kept:)
        key_params.update({n: v for n, v in (("prestrain", prestrain),
                                             ("max_tension", max_tension)) if v is not None})
        kw.setdefault("history", _history_path(key_params, {"history_dir": history_dir}, name))
        kw.setdefault("progress", False)
        if "resume" in inspect.signature(fn).parameters:
            # the deposits: a case stopped or killed goes on from its last checkpoint (on a
            # Dask worker, which cannot catch Ctrl-C, the periodic one)
            kw.setdefault("resume", True)
            kw.setdefault("checkpoint_every", 60)
        return not_interrupted(fn(**kw), name, params).scalars()

    experiment.__name__ = experiment.__qualname__ = name
    return experiment


def check_paper_cases(name, cases, fixed) -> None:
    """Refuse, before anything runs, a case of a paper test with a parameter the test does
    not take, a wire it cannot build, a bad scale or solver options out of range (naming
    the case, the field and the allowed values): such a case would fail the same way on
    every attempt.  Each case is validated by the test's config
    (:meth:`engine.experiments.config.TestConfig.from_kwargs`, through ``check_args``)."""
    from engine import experiments
    from engine.experiments.common import check_scale
    from engine.experiments.params import check_args

    sig = inspect.signature(getattr(experiments, name)).parameters
    allowed = (set(sig) - {"wire_law"}) | {"k", "prestrain", "max_tension", "history_dir"}
    for c in cases:
        params = dict(fixed, **c)
        bad = sorted(set(params) - allowed)
        if bad:
            raise ValueError(f"{name} takes no parameter {', '.join(map(repr, bad))}; its "
                             f"parameters are {', '.join(sorted(allowed))}")
        try:
            _law(params.get("wire", "elastic"), params.get("k"), params.get("prestrain"),
                 params.get("max_tension"))
            check_scale(params.get("scale", sig["scale"].default))
            check_args(name, {n: params.get(n, p.default) for n, p in sig.items()
                              if n != "wire"})          # (the sweep's wire is a law's name)
        except ValueError as e:
            raise ValueError(f"{name}, case {c}: {str(e).removeprefix(name + ': ')}") from None


#: The paper's tests (and the wire pull-out test) by name, as campaign experiments (JSON-able parameters in, scalars
#: out); read-only.
EXPERIMENTS: Mapping[str, Callable] = MappingProxyType(
    {n: _paper_test(n) for n in ("cylinder_triaxial", "box_triaxial", "slope_deposit",
                                 "gravity_deposit", "pullout_test")})


def resolve(experiment) -> Callable:
    """The callable of an experiment: a name of :data:`EXPERIMENTS` or a callable."""
    if isinstance(experiment, str):
        try:
            return EXPERIMENTS[experiment]
        except KeyError:
            raise ValueError(f"unknown experiment {experiment!r}; known: "
                             f"{', '.join(EXPERIMENTS)} (or pass a function)") from None
    if not callable(experiment):
        raise ValueError(f"experiment must be a callable or a name, got {experiment!r}")
    return experiment


