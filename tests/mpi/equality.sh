#!/usr/bin/env bash
# The rank-count equality test of `sph run --mpi`: each case run in one
# process, then under `mpirun -np 1..4` (oversubscribed on a small
# machine); particles.csv must be byte for byte the single run's, and
# summary.json the same once the timing, thread and rank keys are dropped.
#
# Usage: tests/mpi/equality.sh [SPH_BINARY] (built with --features mpi).
set -euo pipefail
sph="$(realpath "${1:-target/release/sph}")"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# Small, short runs that still rebuild their lists and migrate particles.
cases=(
  "couette --resolution 24 --t-end 0.05 --output-interval 0.025"
  "taylor-green --resolution 32 --t-end 0.05 --output-interval 0.025"
  "lid-driven-cavity --resolution 24 --t-end 0.2 --output-interval 0.1"
  # Adaptive step, energy budget, wall particles, a free surface.
  "dam-break --resolution 12 --t-end 0.1 --output-interval 0.05"
)
# summary.json without the keys that depend on the machine or the run's
# layout (timing, threads, ranks, provenance).
strip() {
  python3 - "$1" <<'PY'
import json, sys
drop = ("wall_seconds", "threads", "ranks", "timestamp", "host", "git_commit", "command")
def clean(v):
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items() if not any(d in k for d in drop)}
    if isinstance(v, list):
        return [clean(x) for x in v]
    return v
print(json.dumps(clean(json.load(open(sys.argv[1]))), sort_keys=True, indent=1))
PY
}
failed=0
for c in "${cases[@]}"; do
  name="${c%% *}"
  # shellcheck disable=SC2086
  "$sph" run $c --threads 1 --quiet --out "$work/$name-single"
  strip "$work/$name-single/summary.json" > "$work/$name-single.json"
  # Ranks x threads per rank; the last is hybrid.
  for layout in 1x1 2x1 3x1 4x1 2x2; do
    np="${layout%x*}"
    threads="${layout#*x}"
    dir="$work/$name-$layout"
    # shellcheck disable=SC2086
    mpirun -np "$np" "$sph" run $c --threads "$threads" --quiet --mpi --out "$dir"
    strip "$dir/summary.json" > "$dir.json"
    if cmp -s "$work/$name-single/particles.csv" "$dir/particles.csv" && cmp -s "$work/$name-single.json" "$dir.json"; then
      echo "$name, $np ranks x $threads threads: particles.csv ($(wc -l < "$dir/particles.csv") rows) and summary.json identical to one process"
    else
      echo "$name, $np ranks x $threads threads: DIFFERS from one process"
      cmp "$work/$name-single/particles.csv" "$dir/particles.csv" || true
      diff "$work/$name-single.json" "$dir.json" | head -20 || true
      failed=1
    fi
  done
done
# --vtk on ranks: one .pvtu per output time joining a piece per rank, read
# back by VTK's parallel reader and compared with the single run's CSV.
if [ -n "${VTK_PYTHON:-}" ]; then
  c="${cases[1]}"
  name="${c%% *}"
  # shellcheck disable=SC2086
  mpirun -np 3 "$sph" run $c --threads 1 --quiet --mpi --vtk --out "$work/vtk"
  "$VTK_PYTHON" "$(dirname "$0")/check_pvtu.py" "$work/vtk" 3 "$work/$name-single/particles.csv" || failed=1
fi
exit "$failed"
