#!/usr/bin/env bash
# Instructions per control cycle (and per kinematics call) with callgrind: load-independent
# figures for a noisy machine. For each target the driver runs N1 and N2 iterations under
# `valgrind --tool=callgrind`; (Ir(N2) - Ir(N1)) / (N2 - N1) is the cost of one iteration
# without start-up and set-up.
#
#   bench/instructions.sh                 # control cycles + kinematics calls, libm (no_std) math
#   bench/instructions.sh --std-math      # the same with the platform libm (glibc) sin/cos
#   bench/instructions.sh caster caster-inverse   # only these targets
#   bench/instructions.sh link-open link-keyed    # link codec: one command + one telemetry frame
#   bench/instructions.sh balance balance-f64     # ballbot balance controller, one cycle (f32, f64)
#
# Needs valgrind. Builds the driver (crate bench/rust-harness) in release mode with --locked.
set -euo pipefail
cd "$(dirname "$0")/.."

features=()
targets=()
for a in "$@"; do
  case "$a" in
    --std-math) features=(--features std-math) ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) targets+=("$a") ;;
  esac
done
if [ ${#targets[@]} -eq 0 ]; then
  targets=(sphere ballbot caster
           sphere-inverse ballbot-inverse caster-inverse
           sphere-forward ballbot-forward caster-forward
           sphere-odometry ballbot-odometry caster-odometry)
fi
command -v valgrind >/dev/null || { echo "valgrind not found (apt-get install valgrind)" >&2; exit 1; }

cargo build --release --locked -q -p omnikin-bench "${features[@]}" --bin omnikin-cycle-driver
target_dir=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
driver="$target_dir/release/omnikin-cycle-driver"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
N1=1000
N2=11000
ir() { # ir WHAT N -> total instructions executed
  valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" "$driver" "$1" "$2" >/dev/null 2>"$tmp/vg.err" \
    || { cat "$tmp/vg.err" >&2; exit 1; }
  awk '/^summary:/ {print $2}' "$tmp/cg.out"
}
printf '%-18s %12s\n' "target" "instr/iter"
for t in "${targets[@]}"; do
  a=$(ir "$t" $N1)
  b=$(ir "$t" $N2)
  python3 -c "print(f'{\"$t\":<18} {($b - $a) / ($N2 - $N1):12.1f}')"
done
