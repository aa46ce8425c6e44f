"""Reads a `sph run --mpi --vtk` output set with VTK's own parallel reader
and checks it against the single-process run's particles.csv: every output
time listed in particles.pvd as a .pvtu of one piece per rank, every
particle once, with the positions, velocities and densities of the CSV
(bit for bit: the CSV's shortest round-trip text parses to the same
double).

Usage: check_pvtu.py DIR RANKS SINGLE_PARTICLES_CSV
"""
import csv
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPUnstructuredGridReader

out, ranks, single = sys.argv[1], int(sys.argv[2]), sys.argv[3]

rows = {}
with open(single) as f:
    for r in csv.DictReader(f):
        rows.setdefault(float(r["t"]), []).append(r)

datasets = ET.parse(os.path.join(out, "particles.pvd")).getroot().iter("DataSet")
times = [(float(d.get("timestep")), d.get("file")) for d in datasets]
assert [t for t, _ in times] == sorted(rows), (times, sorted(rows))
for t, name in times:
    assert name.endswith(".pvtu"), name
    pieces = [p.get("Source") for p in ET.parse(os.path.join(out, name)).getroot().iter("Piece")]
    assert len(pieces) == ranks, (name, pieces)
    reader = vtkXMLPUnstructuredGridReader()
    reader.SetFileName(os.path.join(out, name))
    reader.Update()
    grid = reader.GetOutput()
    data = grid.GetPointData()
    ids = vtk_to_numpy(data.GetArray("id"))
    want = rows[t]
    assert sorted(ids.tolist()) == list(range(len(want))), f"{name}: ids are not each particle once"
    x = vtk_to_numpy(grid.GetPoints().GetData())
    v = vtk_to_numpy(data.GetArray("velocity"))
    rho = vtk_to_numpy(data.GetArray("density"))
    order = np.argsort(ids)
    exact_x = np.array([[float(r["x"]), float(r["y"])] for r in want])
    exact_v = np.array([[float(r["vx"]), float(r["vy"])] for r in want])
    exact_rho = np.array([float(r["rho"]) for r in want])
    assert np.array_equal(x[order][:, :2], exact_x), f"{name}: positions differ"
    assert np.array_equal(v[order][:, :2], exact_v), f"{name}: velocities differ"
    assert np.array_equal(rho[order], exact_rho), f"{name}: densities differ"
    print(f"{name}: {len(ids)} particles in {ranks} pieces, read by VTK {reader.GetClassName()}, equal to the single run's CSV at t = {t}")
