#!/usr/bin/env bash
# Fuzzing on stable Rust: builds the targets with libFuzzer's coverage instrumentation (the
# flags `cargo fuzz build --sanitizer none` passes; no nightly, no cargo-fuzz needed), writes
# the seed corpora (gen_corpus, which also checks every seed is valid), runs the targets and
# prints how many inputs each executed.
#
#   fuzz/run.sh [SECONDS] [TARGET...]   build, seed, run each target SECONDS (default 60)
#   fuzz/run.sh build                   build only
#   fuzz/run.sh repro TARGET FILE...    run TARGET on saved inputs (e.g. a finding)
#
# Environment: FUZZ_JOBS targets at a time (default: the number of cores); FUZZ_MAX_LEN
# largest input, bytes (default 8192); FUZZ_SKIP_UNAVAILABLE=1 (CI) exits 0, loudly, when the
# fuzzer cannot be built here (no C++ compiler for libFuzzer, crates not fetchable) instead of
# failing. A finding (crash, failed check, timeout, memory limit) makes the run fail; the input
# is in fuzz/artifacts/TARGET/.
set -euo pipefail
cd "$(dirname "$0")"

ALL=(frame_decoder link_session robot_toml profile_toml waypoints csv_tables mcap_files mcap_messages ros2_cdr)
TRIPLE=$(rustc -vV | sed -n 's/^host: //p')
BIN="target/$TRIPLE/release"
FLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4"
FLAGS+=" -Cllvm-args=-sanitizer-coverage-inline-8bit-counters"
FLAGS+=" -Cllvm-args=-sanitizer-coverage-pc-table"
FLAGS+=" -Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing"
FLAGS+=" -Cllvm-args=-simplifycfg-branch-fold-threshold=0"
FLAGS+=" -Cllvm-args=-sanitizer-coverage-stack-depth -Cdebug-assertions -Ccodegen-units=1"

unavailable() {
  echo "!! FUZZING SKIPPED: $1" >&2
  if [[ "${FUZZ_SKIP_UNAVAILABLE:-0}" == 1 ]]; then
    exit 0
  fi
  exit 1
}

build() {
  if ! command -v c++ >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1; then
    echo "installing a C++ compiler for libFuzzer (Debian package g++)"
    local sudo=""
    [[ "$(id -u)" -ne 0 ]] && command -v sudo >/dev/null && sudo="sudo -n"
    ($sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq g++) \
      >/dev/null 2>&1 || true
  fi
  command -v c++ >/dev/null 2>&1 || unavailable "no C++ compiler (c++) to build libFuzzer"
  local out
  if ! out=$(cargo fetch --locked 2>&1); then
    echo "$out" >&2
    # A stale lock file is this repository's fault, not the machine's.
    if grep -q "cannot update the lock file" <<<"$out"; then
      echo "fuzz/Cargo.lock is out of date: run cargo once without --locked in fuzz/" >&2
      exit 1
    fi
    unavailable "cannot fetch the fuzz crate's dependencies"
  fi
  local t0=$SECONDS
  RUSTFLAGS="$FLAGS" cargo build --locked --release --target "$TRIPLE" --bins --quiet \
    --config 'profile.release.debug="line-tables-only"'
  echo "built the fuzz targets in $((SECONDS - t0)) s"
}

run_one() { # target seconds
  local t=$1 secs=$2
  mkdir -p "corpus/$t" "artifacts/$t" logs
  "$BIN/$t" "corpus/$t" -max_total_time="$secs" -max_len="${FUZZ_MAX_LEN:-8192}" \
    -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="artifacts/$t/" >"logs/$t.log" 2>&1
}

case "${1:-}" in
  build)
    build
    exit 0
    ;;
  repro)
    shift
    t=${1:?target}
    shift
    build
    exec "$BIN/$t" "$@"
    ;;
esac

SECS=${1:-60}
shift || true
TARGETS=("$@")
[[ ${#TARGETS[@]} -gt 0 ]] || TARGETS=("${ALL[@]}")
JOBS=${FUZZ_JOBS:-$(nproc)}

build
"$BIN/gen_corpus" corpus

declare -A rc
pending=("${TARGETS[@]}")
while [[ ${#pending[@]} -gt 0 ]]; do
  batch=("${pending[@]:0:$JOBS}")
  pending=("${pending[@]:$JOBS}")
  declare -A pid=()
  for t in "${batch[@]}"; do
    run_one "$t" "$SECS" &
    pid[$t]=$!
  done
  for t in "${batch[@]}"; do
    if wait "${pid[$t]}"; then rc[$t]=0; else rc[$t]=$?; fi
  done
done

total=0
failed=0
printf '%-14s %14s %8s %8s  %s\n' target executions seconds corpus result
for t in "${TARGETS[@]}"; do
  n=$(sed -n 's/^stat::number_of_executed_units: *//p' "logs/$t.log" | tail -1)
  s=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "logs/$t.log" | tail -1)
  c=$(find "corpus/$t" -type f | wc -l)
  total=$((total + ${n:-0}))
  if [[ ${rc[$t]} == 0 ]]; then
    r=ok
  else
    r="FINDING (exit ${rc[$t]}): fuzz/logs/$t.log, input in fuzz/artifacts/$t/"
    failed=1
  fi
  printf '%-14s %14s %8s %8s  %s\n' "$t" "${n:-?}" "${s:-?}" "$c" "$r"
done
printf '%-14s %14s\n' total "$total"
if [[ $failed == 1 ]]; then
  for t in "${TARGETS[@]}"; do
    if [[ ${rc[$t]} != 0 ]]; then
      echo "== $t: end of its log" >&2
      grep -v '^#' "logs/$t.log" | tail -40 >&2
    fi
  done
  exit 1
fi
