"""Run by ``pvpython`` (ParaView's Python), not by pytest: open each PVD given on the
command line with ParaView's PVD reader and dump, for every time step the reader reports,
every block's name, point and cell counts, the range of each component of each array and
its field data (every value).

    pvpython pv_probe.py OUT.json A.pvd [B.pvd ...]
"""
import json
import sys

from paraview import servermanager
from paraview.simple import PVDReader


def leaf(block):
    """The dataset under a (nested) multiblock of one piece."""
    while block is not None and block.IsA("vtkMultiBlockDataSet"):
        block = block.GetBlock(0) if block.GetNumberOfBlocks() else None
    return block


def arrays(data):
    out = {}
    for a in range(data.GetNumberOfArrays()):
        arr = data.GetArray(a)
        n = arr.GetNumberOfTuples()
        out[arr.GetName()] = {
            "tuples": n,
            "components": arr.GetNumberOfComponents(),
            "range": [list(arr.GetRange(c)) if n else None
                      for c in range(arr.GetNumberOfComponents())],
        }
    return out


def fields(data):
    """Field data of a dataset: {name: list of values} (strings for string arrays)."""
    out = {}
    for a in range(data.GetNumberOfArrays()):
        arr = data.GetAbstractArray(a)
        if arr.IsNumeric():
            out[arr.GetName()] = [arr.GetComponent(0, c)
                                  for c in range(arr.GetNumberOfComponents())]
        else:
            out[arr.GetName()] = [arr.GetValue(i) for i in range(arr.GetNumberOfValues())]
    return out


def probe(path):
    reader = PVDReader(FileName=path)
    times = [float(t) for t in reader.TimestepValues]
    frames = []
    for t in times:
        reader.UpdatePipeline(t)
        mb = servermanager.Fetch(reader)
        blocks = []
        for b in range(mb.GetNumberOfBlocks()):
            name = mb.GetMetaData(b).Get(mb.NAME()) if mb.HasMetaData(b) else None
            ds = leaf(mb.GetBlock(b))
            if ds is None:
                blocks.append({"name": name, "points": 0, "cells": 0, "point_data": {},
                               "cell_data": {}, "field_data": {}, "class": None})
                continue
            blocks.append({"name": name, "class": ds.GetClassName(),
                           "points": ds.GetNumberOfPoints(), "cells": ds.GetNumberOfCells(),
                           "bounds": list(ds.GetBounds()) if ds.GetNumberOfPoints() else None,
                           "field_data": fields(ds.GetFieldData()),
                           "point_data": arrays(ds.GetPointData()),
                           "cell_data": arrays(ds.GetCellData())})
        frames.append({"time": t, "blocks": blocks})
    return {"times": times, "frames": frames}


def main():
    out, paths = sys.argv[1], sys.argv[2:]
    result = {p: probe(p) for p in paths}
    with open(out, "w") as f:
        json.dump({"paraview": servermanager.vtkSMProxyManager.GetParaViewSourceVersion(),
                   "pvd": result}, f)


if __name__ == "__main__":
    main()
