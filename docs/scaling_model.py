"""The scaling model of docs/distributed.md: projected parallel efficiency
of `sph run --mpi` for N particles on P ranks, from figures measured on the
development machine (arguments below) and a typical cluster interconnect.

    python3 docs/scaling_model.py [C2 C3]

C2, C3: seconds per particle-step on one core in 2D and 3D (measured:
Taylor-Green's default physics on one rank, see docs/distributed.md).
"""
import math
import sys

c2 = float(sys.argv[1]) if len(sys.argv) > 1 else 1.5e-6
c3 = float(sys.argv[2]) if len(sys.argv) > 2 else 4.5 * c2
# Halo depth in spacings: 2 levels x (1 + skin) x kappa x beta (5.72; the
# 10^5 and 10^6 runs measured 5.7 from their halo counts).
depth = 2 * 1.1 * 2.0 * 1.3
# A record: id, x, v, m, rho, p, ve, dv, drho, rho_aux, shift.
record = {2: 8 * (1 + 5 * 2 + 5), 3: 8 * (1 + 5 * 3 + 5)}
alpha, bandwidth = 2e-6, 10e9  # s per message, bytes/s (100 Gb/s InfiniBand)


def halo(n, p, dim, layout):
    """Halo particles per rank (both sides), for a cube of n particles."""
    side = n ** (1.0 / dim)
    if p == 1:
        return 0.0
    if layout == "slab":
        # Two faces of the whole cross-section; a slab thinner than the
        # depth takes its copies from further ranks too, the count is the same.
        return 2 * depth * side ** (dim - 1)
    s = (n / p) ** (1.0 / dim)  # a cubic (RCB) subdomain's side
    return (s + 2 * depth) ** dim - s**dim


def efficiency(n, p, dim, layout):
    c = c2 if dim == 2 else c3
    h = halo(n, p, dim, layout)
    compute = c * (n / p + h)
    # Per step: the halo refresh, the drift maximum and the after-step
    # verdict, each an all-to-all of counts and one of data (latency ~ P
    # messages), plus the bytes.
    comm = 6 * alpha * (p - 1) + h * record[dim] / bandwidth if p > 1 else 0.0
    return c * n / (p * (compute + comm)), h, comm / (compute + comm)


if __name__ == "__main__":
    n = 1e7
    print(f"c2 = {c2:.3g} s, c3 = {c3:.3g} s per particle-step; alpha {alpha:g} s, {bandwidth/1e9:g} GB/s")
    print("dim layout   P   halo/rank  owned/rank  comm share  efficiency")
    for dim in (2, 3):
        for layout in ("slab", "rcb"):
            for p in (16, 64, 256):
                e, h, share = efficiency(n, p, dim, layout)
                thin = " (slab thinner than the halo)" if layout == "slab" and n ** (1 / dim) / p < depth else ""
                print(f"{dim}D  {layout:5} {p:4} {h:11.0f} {n/p:11.0f} {100*share:9.2f} % {100*e:9.0f} %{thin}")
