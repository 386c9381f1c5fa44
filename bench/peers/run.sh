#!/usr/bin/env bash
# Side-by-side comparison with WPILib's wpimath (C++), reproducible by anyone:
#
#   bench/peers/run.sh [--rounds N] [--min] [--std-math] [--instructions] [--agree-only] [--keep]
#
# 1. creates a throw-away Python virtual environment in a temporary directory and installs
#    robotpy-native-wpimath (WPILib's C++ headers and shared libraries; it pulls in
#    robotpy-native-wpiutil) from PyPI — nothing from WPILib is in this repository;
# 2. compiles bench/peers/wpimath_harness.cpp with g++ -O2 -std=c++20 against it;
# 3. builds the Rust harness (crate bench/rust-harness, `omnikin-peer-harness`) in release
#    mode with --locked;
# 4. checks that both sides agree to 1e-9 on the mecanum and swerve4 inverse, forward and
#    odometry calls for the same inputs (`--values` of each harness, bench/peers/agree.py),
#    omnikin's side both through the concrete models and through `omnikin::Robot`;
# 5. runs the two alternately for N rounds (default 7; odd rounds C++ first, even rounds Rust
#    first), recording the load average around each round, and prints the median over rounds
#    of each benchmark's per-round median (ns per call) and the ratio WPILib / omnikin for
#    each pair (> 1: omnikin is faster).
#
# --min       each round reports its fastest batch instead of the median batch (a lower bound,
#             less disturbed when other processes load the machine)
# --std-math  build the Rust side with the platform libm's sin/cos (feature std-math) instead
#             of the pure-Rust libm a no_std build uses
# --instructions  also count instructions per call of each side with callgrind (load-independent;
#             needs valgrind): the difference between two run lengths, so set-up cancels
# --agree-only  stop after the agreement check (step 4): no timing, no callgrind (about two
#             minutes, most of it the pip install and the C++ compile)
# --keep      keep the temporary directory (venv, binaries, raw outputs) and print its path
#
# Environment: WPIMATH_VERSION (default 2026.2.2), CXX (default g++), PYTHON (default python3).
set -euo pipefail
cd "$(dirname "$0")/../.."

rounds=7
keep=0
instructions=0
agree_only=0
features=()
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds="$2"; shift 2 ;;
    --min) export OMNIKIN_BENCH_MIN=1; shift ;;
    --std-math) features=(--features std-math); shift ;;
    --keep) keep=1; shift ;;
    --instructions) instructions=1; shift ;;
    --agree-only) agree_only=1; shift ;;
    -h|--help) sed -n '2,32p' "$0"; exit 0 ;;
    *) echo "unknown argument: $1" >&2; exit 2 ;;
  esac
done
version="${WPIMATH_VERSION:-2026.2.2}"
cxx="${CXX:-g++}"
python="${PYTHON:-python3}"

tmp=$(mktemp -d "${TMPDIR:-/tmp}/omnikin-peers.XXXXXX")
if [ "$keep" = 1 ]; then echo "keeping $tmp" >&2; else trap 'rm -rf "$tmp"' EXIT; fi

echo "== WPILib: robotpy-native-wpimath==$version into a throw-away venv" >&2
"$python" -m venv "$tmp/venv"
"$tmp/venv/bin/pip" install --quiet --disable-pip-version-check "robotpy-native-wpimath==$version"
site=$("$tmp/venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
wpimath="$site/native/wpimath"
wpiutil="$site/native/wpiutil"
for d in "$wpimath/include" "$wpimath/lib" "$wpiutil/include" "$wpiutil/lib"; do
  [ -d "$d" ] || { echo "expected $d in the installed package; pip installed:" >&2; "$tmp/venv/bin/pip" list >&2; exit 1; }
done

echo "== C++ harness: $cxx -O2 -std=c++20" >&2
"$cxx" -O2 -std=c++20 bench/peers/wpimath_harness.cpp \
  -I"$wpimath/include" -I"$wpiutil/include" \
  -L"$wpimath/lib" -L"$wpiutil/lib" -lwpimath -lwpiutil \
  -Wl,-rpath,"$wpimath/lib:$wpiutil/lib" -o "$tmp/wpimath_harness"

echo "== Rust harness: cargo build --release --locked -p omnikin-bench ${features[*]}" >&2
cargo build --release --locked --quiet -p omnikin-bench "${features[@]}" --bin omnikin-peer-harness
target_dir=$(cargo metadata --format-version 1 --no-deps | "$python" -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
cp "$target_dir/release/omnikin-peer-harness" "$tmp/omnikin-peer-harness"

echo "== agreement: mecanum and swerve4 inverse/forward/odometry, omnikin vs WPILib (bench/peers/agree.py)" >&2
"$tmp/wpimath_harness" --values > "$tmp/values.cpp"
"$tmp/omnikin-peer-harness" --values > "$tmp/values.rust"
"$python" bench/peers/agree.py "$tmp/values.cpp" "$tmp/values.rust" > "$tmp/agreement" \
  || { cat "$tmp/agreement" >&2; exit 1; }
if [ "$agree_only" = 1 ]; then cat "$tmp/agreement"; exit 0; fi

if [ "$instructions" = 1 ]; then
  command -v valgrind >/dev/null || { echo "--instructions needs valgrind" >&2; exit 1; }
  echo "== instructions per call (callgrind)" >&2
  ir() { # ir BINARY NAME N -> instructions executed by the whole run
    valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" "$1" --count "$2" "$3" >/dev/null 2>"$tmp/vg.err" \
      || { cat "$tmp/vg.err" >&2; exit 1; }
    awk '/^summary:/ {print $2}' "$tmp/cg.out"
  }
  per_call() { # per_call BINARY NAME N1 N2
    local a b
    a=$(ir "$1" "$2" "$3"); b=$(ir "$1" "$2" "$4")
    "$python" -c "print(round(($b - $a) / ($4 - $3), 1))"
  }
  {
    echo "| omnikin | instructions/call | WPILib | instructions/call | WPILib / omnikin |"
    echo "|---|---|---|---|---|"
    for pair in caster_inverse:swerve3_inverse caster_forward:swerve3_forward \
                caster_forward_world:swerve3_forward_world \
                caster_odometry:swerve3_odometry \
                sphere_inverse:swerve3_inverse ballbot_inverse:swerve3_inverse \
                sphere_forward:swerve3_forward ballbot_forward:swerve3_forward \
                sphere_odometry:swerve3_odometry ballbot_odometry:swerve3_odometry \
                mecanum_inverse:wpi_mecanum_inverse mecanum_forward:wpi_mecanum_forward \
                mecanum_odometry:wpi_mecanum_odometry \
                swerve4_inverse:wpi_swerve4_inverse swerve4_forward:wpi_swerve4_forward \
                swerve4_odometry:wpi_swerve4_odometry \
                robot_mecanum_inverse:wpi_mecanum_inverse robot_mecanum_forward:wpi_mecanum_forward \
                robot_mecanum_odometry:wpi_mecanum_odometry \
                robot_swerve4_inverse:wpi_swerve4_inverse robot_swerve4_forward:wpi_swerve4_forward \
                robot_swerve4_odometry:wpi_swerve4_odometry \
                plan20_11hz_time_optimal:plan20_wpilib plan20_1khz_time_optimal:plan20_wpilib \
                plan20_11hz_time_optimal:plan20_wpilib_constrained \
                plan20_1khz_time_optimal:plan20_wpilib_constrained; do
      a=${pair%%:*}; b=${pair#*:}
      case "$a" in plan20_1khz*) n1=1; n2=2 ;; plan20*) n1=1; n2=3 ;; *) n1=1000; n2=11000 ;; esac
      ra=$(per_call "$tmp/omnikin-peer-harness" "$a" $n1 $n2)
      rb=$(per_call "$tmp/wpimath_harness" "$b" $n1 $n2)
      "$python" -c "print(f'| $a | {$ra:,.0f} | $b | {$rb:,.0f} | {$rb / $ra:.2f} |')"
    done
  } > "$tmp/instructions"
fi

loadavg() { cut -d' ' -f1 /proc/loadavg; }
for r in $(seq 1 "$rounds"); do
  l0=$(loadavg)
  if [ $((r % 2)) = 1 ]; then
    "$tmp/wpimath_harness" > "$tmp/cpp.$r"
    "$tmp/omnikin-peer-harness" > "$tmp/rust.$r"
  else
    "$tmp/omnikin-peer-harness" > "$tmp/rust.$r"
    "$tmp/wpimath_harness" > "$tmp/cpp.$r"
  fi
  echo "$r $l0 $(loadavg)" >> "$tmp/load"
  echo "round $r/$rounds done (load ${l0} -> $(loadavg))" >&2
done

"$python" - "$tmp" "$rounds" <<'PY'
import statistics, sys, platform, datetime, os
tmp, rounds = sys.argv[1], int(sys.argv[2])
vals, extra = {}, {}
for side in ("cpp", "rust"):
    for r in range(1, rounds + 1):
        for line in open(f"{tmp}/{side}.{r}"):
            name, ns, ex = line.rstrip("\n").split("\t")
            vals.setdefault(name, []).append(float(ns))
            extra[name] = ex
med = {k: statistics.median(v) for k, v in vals.items()}
loads = [l.split() for l in open(f"{tmp}/load")]
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), platform.processor())
print(f"machine: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}")
print(f"date: {datetime.datetime.now().astimezone().isoformat(timespec='minutes')}")
print(f"rounds: {rounds}; statistic per round: {'fastest batch' if os.environ.get('OMNIKIN_BENCH_MIN') == '1' else 'median batch'}; then median over rounds")
print("load average (1 min) before/after each round: " + ", ".join(f"{a}/{b}" for _, a, b in loads))
def fmt(ns):
    return f"{ns / 1e6:.3f} ms" if ns >= 1e5 else f"{ns:.1f} ns"
print()
print("| omnikin | median | WPILib | median | WPILib / omnikin |")
print("|---|---|---|---|---|")
pairs = [
    ("caster_inverse", "swerve3_inverse"),
    ("caster_forward", "swerve3_forward"),
    ("caster_forward_world", "swerve3_forward_world"),
    ("caster_odometry", "swerve3_odometry"),
    ("sphere_inverse", "swerve3_inverse"),
    ("ballbot_inverse", "swerve3_inverse"),
    ("sphere_forward", "swerve3_forward"),
    ("ballbot_forward", "swerve3_forward"),
    ("sphere_odometry", "swerve3_odometry"),
    ("ballbot_odometry", "swerve3_odometry"),
    ("mecanum_inverse", "wpi_mecanum_inverse"),
    ("mecanum_forward", "wpi_mecanum_forward"),
    ("mecanum_odometry", "wpi_mecanum_odometry"),
    ("swerve4_inverse", "wpi_swerve4_inverse"),
    ("swerve4_forward", "wpi_swerve4_forward"),
    ("swerve4_odometry", "wpi_swerve4_odometry"),
    ("robot_mecanum_inverse", "wpi_mecanum_inverse"),
    ("robot_mecanum_forward", "wpi_mecanum_forward"),
    ("robot_mecanum_odometry", "wpi_mecanum_odometry"),
    ("robot_swerve4_inverse", "wpi_swerve4_inverse"),
    ("robot_swerve4_forward", "wpi_swerve4_forward"),
    ("robot_swerve4_odometry", "wpi_swerve4_odometry"),
    ("plan20_11hz_time_optimal", "plan20_wpilib"),
    ("plan20_1khz_time_optimal", "plan20_wpilib"),
    ("plan20_1khz_trapezoid", "plan20_wpilib"),
    ("plan20_11hz_time_optimal", "plan20_wpilib_constrained"),
    ("plan20_1khz_time_optimal", "plan20_wpilib_constrained"),
]
for a, b in pairs:
    if a in med and b in med:
        print(f"| {a} | {fmt(med[a])} | {b} | {fmt(med[b])} | {med[b] / med[a]:.2f} |")
print()
print("agreement with WPILib (same inputs, bench/peers/agree.py):")
print(open(f"{tmp}/agreement").read())
if os.path.exists(f"{tmp}/instructions"):
    print("instructions per call (callgrind; load-independent):")
    print()
    print(open(f"{tmp}/instructions").read())
print("spread over rounds (min .. max):")
for k in sorted(vals):
    v = vals[k]
    print(f"  {k:<26} {fmt(min(v))} .. {fmt(max(v))}  {extra[k] if extra[k] != '-' else ''}")
PY
