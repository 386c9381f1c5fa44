#!/usr/bin/env bash
# The control-cycle budget: runs bench/instructions.sh for every kind in bench/budgets.toml's
# [cycle] table and fails when a count exceeds its budget by more than the table's tolerance
# (5 %). Counts, not timings: callgrind's instruction count of one cycle does not depend on
# the machine's load.
#
#   bench/check-budgets.sh            # all kinds of the budget file
#   BUDGETS=path/to/budgets.toml bench/check-budgets.sh
#
# Exit 0: every kind within budget; 1: one or more over (each named with its count, budget and
# limit); 2: the budget file or the measurement is unusable.
set -euo pipefail
cd "$(dirname "$0")/.."
budgets="${BUDGETS:-bench/budgets.toml}"

# kind budget tolerance, one line per kind (python3's tomllib reads the file).
table=$(python3 - "$budgets" <<'PY'
import sys, tomllib
path = sys.argv[1]
try:
    with open(path, "rb") as f:
        cycle = tomllib.load(f)["cycle"]
except (OSError, tomllib.TOMLDecodeError, KeyError) as e:
    sys.exit(f"{path}: cannot read the [cycle] table: {e}")
tol = cycle.get("tolerance")
if not isinstance(tol, (int, float)) or not 0 <= tol < 1:
    sys.exit(f"{path}: [cycle] tolerance must be a number in [0, 1), got {tol!r}")
kinds = {k: v for k, v in cycle.items() if k != "tolerance"}
if not kinds:
    sys.exit(f"{path}: [cycle] names no kind")
for k, v in kinds.items():
    if not isinstance(v, int) or v <= 0:
        sys.exit(f"{path}: [cycle] {k} must be a positive integer (instructions), got {v!r}")
    print(k, v, tol)
PY
) || exit 2

kinds=$(awk '{print $1}' <<<"$table")
# shellcheck disable=SC2086
measured=$(bash bench/instructions.sh $kinds) || exit 2
echo "$measured"

fail=0
while read -r kind budget tol; do
  count=$(awk -v k="$kind" '$1 == k {print $2}' <<<"$measured")
  if [ -z "$count" ]; then
    echo "budget: no count measured for '$kind'" >&2
    exit 2
  fi
  verdict=$(python3 -c "
c, b, t = float('$count'), int('$budget'), float('$tol')
lim = b * (1 + t)
print(('OVER' if c > lim else 'ok') + f' {c:.1f} instructions, budget {b}, limit {lim:.0f} (+{t:.0%})')")
  echo "budget: $kind: $verdict"
  case "$verdict" in OVER*) fail=1 ;; esac
done <<<"$table"

if [ "$fail" -ne 0 ]; then
  echo "budget: FAILED: a control cycle grew past its budget in $budgets (make it cheaper, or raise the budget in a commit that says why)" >&2
  exit 1
fi
echo "budget: OK"
