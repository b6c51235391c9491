"""campaign.table reads the tables written by engine.sweep before the move (TABLE_VERSION 1):
the sweep tables committed under bench/results load, each row with its key, status and
result, and a re-run would find its cases by their keys."""
from __future__ import annotations

from pathlib import Path

import pytest

from campaign import TABLE_VERSION, case_key, load_table

RESULTS = Path(__file__).resolve().parents[2] / "bench" / "results"
TABLES = sorted(RESULTS.glob("*-sweep.json")) + [RESULTS / "reinforcement-table-scale1.json"]


@pytest.mark.parametrize("path", TABLES, ids=lambda p: p.name)
def test_committed_tables_still_load(path):
    assert path.exists()
    table = load_table(path)
    assert table.rows and TABLE_VERSION == 1
    for r in table.rows:
        assert {"key", "id", "experiment", "params", "status", "attempts", "errors",
                "result"} <= set(r), path
        # the key a re-run computes for the row's case is the stored one (resume)
        assert case_key(r["experiment"], r["params"]) == r["key"]
