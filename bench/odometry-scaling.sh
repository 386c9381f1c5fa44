#!/usr/bin/env bash
# `omnikin odometry` time and memory against the log's length: O(n) time, memory that does not
# grow with the log (issue 31: a 10⁷-row log, the documented limit MAX_TRACK_ROWS, was held
# whole, some 1.7 GB). A measurement, not a test: it prints figures and asserts nothing
# (timings depend on the machine's load).
#
#   bench/odometry-scaling.sh                  # 10⁵ and 10⁶ rows
#   bench/odometry-scaling.sh 100000 10000000  # any row counts (10⁷ rows: a 550 MB log)
#   OMNIKIN=path/to/omnikin bench/odometry-scaling.sh   # a given binary (default: release build)
#
# Each log is a kiwi encoder log (t,q1,q2,q3,gyro_z at 100 Hz) made with awk in a temporary
# directory (removed at the end); each run is `odometry LOG --robot kiwi --imu --out poses.csv
# --plot fig.svg` under /usr/bin/time. Columns: rows, wall s, user s, user µs per row, peak RSS.
set -euo pipefail
cd "$(dirname "$0")/.."
counts=("$@")
[ ${#counts[@]} -eq 0 ] && counts=(100000 1000000)
bin="${OMNIKIN:-}"
if [ -z "$bin" ]; then
  cargo build --release --locked -p omnikin-cli >&2
  bin="${CARGO_TARGET_DIR:-target}/release/omnikin"
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf '%10s %9s %9s %12s %10s\n' rows wall_s user_s user_us/row peak_MB
for n in "${counts[@]}"; do
  awk -v n="$n" 'BEGIN {
    print "t,q1,q2,q3,gyro_z"
    for (i = 0; i < n; i++) {
      t = i * 0.01
      printf "%.2f,%.6f,%.6f,%.6f,%.6f\n", t, -2 * t, 2 * t + 0.1 * sin(t), 0.1 * sin(t), 0.01 * cos(t)
    }
  }' > "$work/log.csv"
  rm -f "$work/poses.csv" "$work/fig.svg"
  /usr/bin/time -f '%e %U %M' -o "$work/time" \
    "$bin" odometry "$work/log.csv" --robot kiwi --imu --out "$work/poses.csv" --plot "$work/fig.svg" \
    > /dev/null 2> "$work/stderr" || { cat "$work/stderr" >&2; exit 1; }
  read -r wall user rss < "$work/time"
  awk -v n="$n" -v w="$wall" -v u="$user" -v r="$rss" \
    'BEGIN { printf "%10d %9.2f %9.2f %12.2f %10.1f\n", n, w, u, u * 1e6 / n, r / 1024 }'
done
