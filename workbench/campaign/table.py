"""The results table of a campaign: one row per case, stored as JSON (the store of record,
rewritten atomically after every finished case) and HDF5.

The JSON format (:data:`TABLE_VERSION`) is the one ``engine.sweep`` wrote: ``{"version": 1,
"experiment": name, "cases": [row, ...]}``.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np

__all__ = ["SweepTable", "load_table", "update_results", "write_hdf5", "result_row",
           "TABLE_VERSION"]

#: Format version of the JSON table.
TABLE_VERSION = 1


def _scalar(v):
    if isinstance(v, np.generic):
        v = v.item()
    if v is None or isinstance(v, (bool, int, str)):
        return v, True
    if isinstance(v, float):
        return (v if math.isfinite(v) else None), True
    return None, False


def result_row(res: Mapping) -> dict:
    """A case's results as the table stores them: the scalars (non-finite floats as None),
    and the names of the values that are not scalars in ``_dropped``."""
    table, dropped = {}, []
    for k, v in res.items():
        s, ok = _scalar(v)
        if ok:
            table[str(k)] = s
        else:
            dropped.append(str(k))
    if dropped:
        table["_dropped"] = ",".join(dropped)
    return table


@dataclass
class SweepTable:
    """Rows of a sweep, one per case, and where they are stored.

    Each row: ``key`` (see :func:`workbench.campaign.cases.case_key`), ``id``, ``experiment``, ``params``,
    ``status`` ("done" or "failed"), ``attempts``, ``errors`` (one message per failed
    attempt), ``result`` (scalars), ``elapsed`` [s] of the successful attempt, ``worker``,
    ``skipped`` (True when taken from an earlier run).
    """

    rows: list = field(default_factory=list)
    path: str | None = None
    wall_time: float = 0.0

    @property
    def done(self) -> list:
        return [r for r in self.rows if r["status"] == "done"]

    @property
    def failed(self) -> list:
        return [r for r in self.rows if r["status"] == "failed"]

    def find(self, **params) -> dict | None:
        """The row whose parameters include ``params`` (the first one), or None."""
        for r in self.rows:
            if all(r["params"].get(k) == v for k, v in params.items()):
                return r
        return None

    def column(self, name: str) -> np.ndarray:
        """One result (or parameter) across the rows, NaN where missing or not numeric."""
        out = []
        for r in self.rows:
            v = (r.get("result") or {}).get(name, r["params"].get(name))
            out.append(float(v) if isinstance(v, (int, float)) else float("nan"))
        return np.asarray(out)

    def __str__(self):
        return (f"sweep: {len(self.rows)} cases, {len(self.done)} done "
                f"({sum(1 for r in self.done if r.get('skipped'))} skipped as finished), "
                f"{len(self.failed)} failed; {self.wall_time:.1f} s; table {self.path}")


def load_table(path) -> SweepTable:
    """Read a sweep's JSON table (an empty table when the file does not exist)."""
    p = Path(path)
    if not p.exists():
        return SweepTable(path=str(p))
    with open(p) as f:
        data = json.load(f)
    if not isinstance(data, dict) or "cases" not in data:
        raise ValueError(f"{p}: not a sweep table (no 'cases')")
    if int(data.get("version", 0)) > TABLE_VERSION:
        raise ValueError(f"{p}: sweep table version {data['version']} is newer than this "
                         f"code's {TABLE_VERSION}")
    return SweepTable(rows=list(data["cases"]), path=str(p))


def write_json(table: SweepTable, path: Path, meta: dict):
    from engine.files import write_text

    text = json.dumps({"version": TABLE_VERSION, **meta, "cases": table.rows}, indent=1,
                      sort_keys=False, allow_nan=False)
    # atomic: a crash or a full disk leaves the older table as it was
    write_text(path, text, "the sweep table could not be written")


def update_results(path, results: Mapping[str, dict]) -> SweepTable:
    """Replace the ``result`` scalars of the table's done rows named in ``results`` (case id
    -> scalars), as a sweep stores them (non-finite floats as None), and write the table
    back atomically; for results recomputed after the run (a study rescoring its cases from
    their histories) that must outlive the histories."""
    table = load_table(path)
    if not table.rows:
        raise ValueError(f"{path}: no sweep table there")
    for row in table.done:
        if row["id"] in results:
            row["result"] = result_row(results[row["id"]])
    write_json(table, Path(path), dict(experiment=table.rows[0]["experiment"]))
    return table


def write_hdf5(table: SweepTable, path) -> Path:
    """The table as HDF5: one dataset per parameter and per numeric result (NaN where
    missing), ``status``, ``attempts``, ``elapsed`` [s], ``id`` and ``error`` as strings."""
    import h5py

    from engine.files import h5_image, write_bytes

    path = Path(path)
    rows = table.rows

    def build(f):
        f.attrs["content"] = "sweep"
        f.attrs["format_version"] = TABLE_VERSION
        f.attrs["n_cases"] = len(rows)
        str_dt = h5py.string_dtype()
        f.create_dataset("id", data=np.array([r["id"] for r in rows], dtype=object),
                         dtype=str_dt)
        f.create_dataset("status", data=np.array([r["status"] for r in rows], dtype=object),
                         dtype=str_dt)
        f.create_dataset("error", data=np.array([(r["errors"] or [""])[-1] for r in rows],
                                                dtype=object), dtype=str_dt)
        f.create_dataset("attempts", data=np.array([r["attempts"] for r in rows],
                                                   dtype=np.int64))
        el = f.create_dataset("elapsed", data=np.array(
            [r.get("elapsed") if r.get("elapsed") is not None else np.nan for r in rows],
            float))
        el.attrs["unit"] = "s"
        for group, src in (("params", "params"), ("results", "result")):
            g = f.create_group(group)
            names = sorted({k for r in rows for k in (r.get(src) or {})})
            for k in names:
                vals = [(r.get(src) or {}).get(k) for r in rows]
                if all(v is None or isinstance(v, (int, float, bool)) for v in vals):
                    g.create_dataset(k, data=np.array([np.nan if v is None else float(v)
                                                       for v in vals]))
                else:
                    g.create_dataset(k, data=np.array(["" if v is None else json.dumps(v)
                                                       if not isinstance(v, str) else v
                                                       for v in vals], dtype=object),
                                     dtype=str_dt)

    write_bytes(path, h5_image(build), "the sweep table could not be written")
    return path
