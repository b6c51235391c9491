"""engine.errors: every error and warning type in one module that imports nothing of the
engine (any layer may raise them without an import circle), and each one still reachable,
as the same class, where it was first defined (DESIGN §5: names are kept)."""
from __future__ import annotations

import ast
import importlib
import inspect

import pytest

import engine.errors as errors

HOMES = [("engine.step", "SimulationError"), ("engine.step", "NonConvergenceWarning"),
         ("engine", "SimulationError"), ("engine.sanity", "PhysicsWarning"),
         ("engine.drivers", "ConfinementError"), ("engine.experiments.common", "ConvergenceError"),
         ("engine.experiments", "ConvergenceError"), ("engine.io", "FormatError"),
         ("engine.io", "FileProblem"), ("engine.io", "WriteFailed"), ("engine.io", "RunLocked"),
         ("engine.checks", "InputError"), ("engine.prep.deposit", "DepositError"),
         ("engine.prep", "DepositError")]


@pytest.mark.parametrize("module, name", HOMES)
def test_each_error_is_the_same_class_at_its_old_home(module, name):
    assert getattr(importlib.import_module(module), name) is getattr(errors, name)


def test_errors_module_imports_nothing_of_the_engine():
    tree = ast.parse(inspect.getsource(errors))
    imported = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    imported += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                 if n.level == 0]
    relative = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level > 0]
    assert not relative and not any(m.split(".")[0] == "engine" for m in imported), imported
    assert sorted(errors.__all__) == sorted(
        n for n, v in vars(errors).items() if isinstance(v, type) and issubclass(v, Exception))


def test_one_line_messages_and_payloads():
    e = errors.WriteFailed("out/h.h5", 28, "No space left on device")
    assert str(e) == "out/h.h5: No space left on device" and e.errno == 28
    d = errors.DepositError("placed 3 of 5 grains", 3, [[0, 0, 0]] * 3, [1e-4] * 3)
    assert d.placed == 3 and isinstance(d, ValueError)
    c = errors.ConvergenceError("too many", result={"steps": 10})
    assert c.result == {"steps": 10} and isinstance(c, RuntimeError)
