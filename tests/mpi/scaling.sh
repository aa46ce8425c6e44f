#!/usr/bin/env bash
# The scaling table of docs/distributed.md: Taylor-Green at 10^5 and 10^6
# particles as 1x1, 2x1 and 1x2 ranks x threads, all through the engine
# (mpirun --mpi); time per step from the slowest rank's own accounts
# (stepping + halo + reduction + migration), without set-up and outputs.
# Usage: tests/mpi/scaling.sh [SPH_BINARY built with --features mpi]
S="$(realpath "${1:-target/release/sph}")"
cd "$(mktemp -d)"
one() { # res t np threads rep
  out=p3-$1-$3x$4-$5
  mpirun -np $3 $S run taylor-green --resolution $1 --t-end $2 --output-interval $2 --threads $4 --mpi --quiet --out $out >/dev/null 2>&1
  python3 - $out $1 $3 $4 $5 <<'PY'
import json, sys
d = json.load(open(sys.argv[1] + "/summary.json"))
r = d["ranks_detail"]; steps = d["steps"]
loop = [x["step_seconds"] + x["halo_seconds"] + x["reduce_seconds"] + x["migrate_seconds"] for x in r]
comm = [x["halo_seconds"] + x["reduce_seconds"] + x["migrate_seconds"] for x in r]
mig = [x["migrate_seconds"] for x in r]
print("P3 N=%d %sx%s rep %s steps %d: per step %.4f s (max over ranks), comm share %.1f %% (migration %.1f %%), halo/rank %d, owned/rank %d, bytes/rank/step %.0f, wall %.1f" % (
    d["n_fluid"], sys.argv[3], sys.argv[4], sys.argv[5], steps, max(loop) / steps,
    100 * max(comm) / max(loop), 100 * max(mig) / max(loop),
    sum(x["halo"] for x in r) / len(r), sum(x["owned"] for x in r) / len(r),
    sum(x["bytes_sent"] for x in r) / len(r) / steps, d["wall_seconds"]), flush=True)
PY
}
for rep in 1 2 3; do
  for l in "1 1" "2 1" "1 2"; do one 316 0.0039 $l $rep; done
done
for l in "1 1" "2 1" "1 2"; do one 1000 0.000414 $l 1; done
