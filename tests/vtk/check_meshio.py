"""Reads sph's VTK output with meshio, an independent reader, and checks it
against the CSV files of the same run (CI runs this; see .ci/run).

Usage: python check_meshio.py SPH_BINARY WORKDIR
"""

import csv
import json
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np

sph, work = sys.argv[1], Path(sys.argv[2])


def run(*args):
    subprocess.run([sph, *args], check=True, stdout=subprocess.DEVNULL)


def check_set(out: Path, rows_by_time, label):
    """Every .vtu of the .pvd: ids, positions, velocities, exact velocities
    and errors equal the CSV's values (binary: to the bit)."""
    pvd = (out / "particles.pvd").read_text()
    summary = json.loads((out / "summary.json").read_text())
    files = sorted(out.glob("particles_*.vtu"))
    assert files and all(f.name in pvd for f in files), label
    times = sorted(rows_by_time)
    assert len(files) == len(times), (label, len(files), len(times))
    for f, t in zip(files, times):
        mesh = meshio.read(f)
        rows = rows_by_time[t]
        n = len(rows)
        assert mesh.points.shape == (n, 3), (label, mesh.points.shape)
        pd = mesh.point_data
        assert np.array_equal(np.ravel(pd["id"]), np.arange(n)), label
        x = np.array([r["x"] for r in rows])
        v = np.array([r["v"] for r in rows])
        assert np.array_equal(mesh.points, x), (label, f.name)
        assert np.array_equal(pd["velocity"], v), (label, f.name)
        # The error array is |v - v_exact| over the error scale: its largest
        # value is the summary's L-infinity error at that time.
        err = np.ravel(pd["error"])
        dv = np.linalg.norm(pd["velocity"] - pd["velocity_exact"], axis=1)
        scale = dv.max() / err.max()
        assert np.allclose(err * scale, dv, rtol=1e-12, atol=0), label
        linf = summary["outputs"][times.index(t)]["linf"]
        assert abs(err.max() - linf) <= 1e-12 * linf, (label, err.max(), linf)
    print(f"{label}: {len(files)} snapshots of {n} particles read back by meshio")


# Couette (2D, exact series): profile.csv has t, y, vx, vx_exact; positions
# come from particles in row order, so compare velocity columns.
couette = work / "couette"
run("couette", "--quiet", "--particles-across", "16", "--t-end", "0.05",
    "--output-times", "0.0225,0.05", "--vtk", "--overwrite", "--out", str(couette))
by_t = {}
with open(couette / "profile.csv") as fh:
    for r in csv.DictReader(fh):
        by_t.setdefault(float(r["t"]), []).append(r)
for f, t in zip(sorted(couette.glob("particles_*.vtu")), sorted(by_t)):
    mesh = meshio.read(f)
    rows = by_t[t]
    assert np.array_equal(mesh.points[:, 1], [float(r["y"]) for r in rows]), f
    assert np.array_equal(mesh.point_data["velocity"][:, 0], [float(r["vx"]) for r in rows]), f
    assert np.array_equal(
        mesh.point_data["velocity_exact"][:, 0], [float(r["vx_exact"]) for r in rows]
    ), f
print(f"couette: {len(by_t)} snapshots match profile.csv")

# Scenes in 2D and 3D (particles.csv: t, id, x, y, z, vx, vy, vz, ...), with
# ASCII as well as binary encoding.
for case, extra in [
    ("taylor-green", ["--resolution", "16", "--t-end", "0.02", "--output-interval", "0.01"]),
    ("poiseuille", ["--resolution", "8", "--dim", "3", "--t-end", "0.01", "--output-interval", "0.005"]),
]:
    for encoding in ["binary", "ascii"]:
        out = work / f"{case}-{encoding}"
        flags = ["--vtk-ascii"] if encoding == "ascii" else []
        run("run", case, "--quiet", *extra, "--vtk", *flags, "--overwrite", "--out", str(out))
        by_t = {}
        with open(out / "particles.csv") as fh:
            for r in csv.DictReader(fh):
                z, vz = float(r.get("z", 0.0)), float(r.get("vz", 0.0))
                by_t.setdefault(float(r["t"]), []).append({
                    "x": [float(r["x"]), float(r["y"]), z],
                    "v": [float(r["vx"]), float(r["vy"]), vz],
                })
        check_set(out, by_t, f"{case} {encoding}")
