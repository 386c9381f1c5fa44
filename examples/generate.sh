#!/bin/sh
# Regenerates every generated file of examples/ with omnikin itself (seeded: the same files
# come out on any machine and thread count). Run from anywhere:
#   examples/generate.sh            # uses `omnikin` from PATH, or OMNIKIN=path/to/omnikin
# Hand-written inputs (waypoints.*, profiles/*.toml) are not touched.
set -eu
cd "$(dirname "$0")"
OMNIKIN=${OMNIKIN:-omnikin}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
run() { "$OMNIKIN" --force "$@" 2>/dev/null; }

# Plans: the tour's two, and one 0.4 m square at 0.2 m/s per robot kind.
run plan circle --robot sphere-omni --radius 0.2 --omega 0.5 --out plans/circle-sphere.csv
run plan waypoints waypoints.csv --robot caster3 --path spline --heading-law tangent \
    --time-optimal --max-speed 1 --max-accel 2 --out plans/tour-caster3.csv
for r in sphere-omni ballbot caster3 kiwi x-drive mecanum; do
    run plan square --robot "$r" --side 0.4 --speed 0.2 --out "plans/square-$r.csv"
done
# swerve4's file limits acceleration to 1 m/s²: the paper's 5 % ramps (0.1 s to 0.2 m/s) would
# ask 2 m/s², so its ramps take 12.5 % of a leg (0.25 s, 0.8 m/s²).
run plan square --robot swerve4 --side 0.4 --speed 0.2 --ramp-fraction 0.125 \
    --out plans/square-swerve4.csv

# Tracked runs: three simulated runs of the circle seen by a "video tracker" -- the tracked
# marker (tracked_x, tracked_y of trials.csv: 3 mm noise) at 25 frames/s (every 4th plan
# sample), the camera started 0.48 s before the robot (12 frames at the start point).
run simulate plans/circle-sphere.csv --robot sphere-omni --disturbances profiles/tracker.toml \
    --trials 3 --seed 7 --out "$work/tracker" >/dev/null
for i in 0 1 2; do
    awk -F, -v trial="$i" '
        NR == 1 { print "t,x,y"; next }
        $1 != trial { next }
        { n++ }
        n == 1 { for (k = 0; k < 12; k++) printf "%.2f,%.4f,%.4f\n", k * 0.04, $6, $7 }
        (n - 1) % 4 == 0 { printf "%.2f,%.4f,%.4f\n", $2 + 0.48, $6, $7 }
    ' "$work/tracker/trials.csv" > "tracked/run$((i + 1)).csv"
done

# Encoder logs with camera fixes: one simulated kiwi square, recorded by profiles/sensors.toml.
run simulate plans/square-kiwi.csv --robot kiwi --disturbances profiles/slip.toml --trials 1 \
    --seed 3 --emit-sensors --sensors profiles/sensors.toml --out "$work/kiwi" >/dev/null
cp "$work/kiwi/sensors/trial-000/encoders.csv" logs/kiwi-encoders.csv
cp "$work/kiwi/sensors/trial-000/fixes.csv" logs/kiwi-fixes.csv
cp "$work/kiwi/sensors/trial-000/truth.csv" logs/kiwi-truth.csv
# The figures the README shows (docs/figures/tour-*.svg): the tour's own commands.
run plan waypoints waypoints.csv --robot caster3 --path spline --heading-law tangent \
    --time-optimal --max-speed 1 --max-accel 2 --out "$work/tour.csv" --plot ../docs/figures/tour-plan.svg
run simulate plans/circle-sphere.csv --robot sphere-omni --disturbances profiles/noisy.toml \
    --trials 20 --seed 1 --out "$work/sim" >/dev/null
cp "$work/sim/figure.svg" ../docs/figures/tour-simulate.svg
run evaluate --plan plans/circle-sphere.csv tracked/run1.csv tracked/run2.csv tracked/run3.csv \
    --out "$work/eval" >/dev/null
cp "$work/eval/figure.svg" ../docs/figures/tour-evaluate.svg
run odometry --robot kiwi logs/kiwi-encoders.csv --fixes logs/kiwi-fixes.csv --initial-pose 0,0,0 \
    --out "$work/fused.csv" --plot ../docs/figures/tour-odometry.svg
run reproduce sphere-2019 --profiles ideal,hardware --trials 3 --out "$work/reproduce" >/dev/null
cp "$work/reproduce/circle-0.4-hardware.svg" ../docs/figures/tour-reproduce.svg
# docs/maps.md's figure: the example map crossed corner to corner (issue 40).
run plan goal --robot sphere-omni --map maps/cluttered.toml --from 0.5,0.5 --to 9.5,9.5,1.57 \
    --rate 20 --out "$work/goal.csv" --plot ../docs/figures/maps-goal.svg
echo "examples regenerated with $("$OMNIKIN" --version)"
