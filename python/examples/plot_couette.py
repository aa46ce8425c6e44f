"""Plane Couette flow from Python: run sph's Couette case in pieces, read
the particles as numpy arrays, and plot the velocity profiles against the
exact series with matplotlib.

    pip install ./python matplotlib
    python python/examples/plot_couette.py          # writes couette-python.png
"""

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sph  # noqa: E402

GAP, U, NU = 1e-3, 1.25e-5, 1e-6  # sph couette's defaults


def exact(y, t):
    """u(y, t) with y from the plate at rest (docs/physics.md 6.a)."""
    u = U * y / GAP
    for n in range(1, 400):
        u += 2 * U * (-1) ** n / (n * math.pi) * np.sin(n * math.pi * y / GAP) * math.exp(
            -((n * math.pi) ** 2) * NU * t / GAP**2
        )
    return u


# %% Run 20 across to t = 0.5 s, stopping at four times to take a profile.
sim = sph.Simulation.couette("particles_across = 20\nt_end = 0.5\noutput_times = [0.05, 0.1, 0.2, 0.5]")
print(sim)
fig, ax = plt.subplots(figsize=(6, 4))
for t_stop in (0.05, 0.1, 0.2, 0.5):
    while sim.time < t_stop - 1e-12 and not sim.ended:
        sim.advance(1)
    y = sim.positions[:, 1] + GAP / 2
    u = sim.velocities[:, 0]
    order = np.argsort(y)
    line = ax.plot(u[order] / U, y[order] / GAP, ".", ms=3, label=f"sph, t = {sim.time:.2f} s")
    fine = np.linspace(0, GAP, 200)
    ax.plot(exact(fine, sim.time) / U, fine / GAP, "-", color=line[0].get_color(), lw=0.8)

# %% The library's own error against the same series, at each output time.
for d in sim.diagnostics():
    print(f"t = {d['t']:.3f} s: L-inf error {d['linf']:.3e} U, L2 {d['l2']:.3e} U")
ax.set_xlabel("u / U")
ax.set_ylabel("y / H")
ax.set_title("Couette flow from Python: sph (dots) and the exact series (lines)")
ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig("couette-python.png", dpi=120)
print("wrote couette-python.png")
