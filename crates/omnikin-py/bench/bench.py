"""Speed of the vectorised kinematics (README "Python" section quotes its figures).

1. 10^6 caster3 inverse rows in one call (target: under 50 ms): at one steer state (no steer
   argument: zeros; the core's fixed-steer path, Caster3::robot_frame_inverse) and with a
   steer row per twist (the trigonometry of every row).
2. The same count through a Python loop over robotpy-wpimath's
   `SwerveDrive3Kinematics.toSwerveModuleStates` (pip install robotpy-wpimath), against our
   vectorised call for the same three-module swerve (a robot file written here) and for caster3
   (target: at least 100x). Without robotpy-wpimath, part 2 is skipped with a message.

Run: python crates/omnikin-py/bench/bench.py [--rows N]; build the package in release mode
first (pip install ./crates/omnikin-py, or maturin develop --release).
"""

import argparse
import math
import os
import tempfile
import time

import numpy as np

import omnikin

SWERVE3 = """kind = "swerve"
name = "swerve3"
[geometry]
optimize_steering = false
{modules}
"""
MODULE = "[[geometry.modules]]\nposition = [{x!r}, {y!r}]\nwheel_radius = 0.05\n"
POSITIONS = [(0.3 * math.cos(a), 0.3 * math.sin(a)) for a in (0.0, 2 * math.pi / 3, 4 * math.pi / 3)]


def best_of(f, repeat=5):
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=1_000_000)
    n = ap.parse_args().rows
    rng = np.random.default_rng(0)
    tw = rng.uniform(-1.0, 1.0, size=(n, 3))

    caster = omnikin.Robot("caster3")
    t_caster = best_of(lambda: caster.inverse(tw))
    threads = os.environ.get("RAYON_NUM_THREADS", f"all {os.cpu_count()} cores")
    print(f"caster3 inverse, {n} rows, one call, one steer state: {t_caster * 1e3:.1f} ms "
          f"({t_caster / n * 1e9:.1f} ns/row; target < 50 ms for 10^6), threads: {threads}")
    steer = rng.uniform(-3.0, 3.0, size=(n, 3))
    t_caster_rows = best_of(lambda: caster.inverse(tw, steer=steer))
    print(f"caster3 inverse, {n} rows, one call, a steer row per twist: "
          f"{t_caster_rows * 1e3:.1f} ms ({t_caster_rows / n * 1e9:.1f} ns/row)")

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "swerve3.toml")
        with open(path, "w") as f:
            f.write(SWERVE3.format(modules="".join(MODULE.format(x=x, y=y) for x, y in POSITIONS)))
        swerve = omnikin.Robot(path)
    t_swerve = best_of(lambda: swerve.inverse(tw))
    print(f"swerve3 inverse, {n} rows, one call: {t_swerve * 1e3:.1f} ms")

    try:
        from wpimath.geometry import Translation2d
        from wpimath.kinematics import ChassisSpeeds, SwerveDrive3Kinematics
    except ImportError:
        print("robotpy-wpimath not installed: comparison skipped (pip install robotpy-wpimath)")
        return
    kin = SwerveDrive3Kinematics(*(Translation2d(x, y) for x, y in POSITIONS))
    rows = tw.tolist()

    def loop():
        for vx, vy, wz in rows:
            kin.toSwerveModuleStates(ChassisSpeeds(vx, vy, wz))

    t0 = time.perf_counter()
    loop()
    t_wpi = time.perf_counter() - t0
    print(f"robotpy-wpimath SwerveDrive3Kinematics.toSwerveModuleStates, Python loop of {n}: "
          f"{t_wpi * 1e3:.0f} ms")
    print(f"speed-up: {t_wpi / t_swerve:.0f}x (swerve3, the same robot), "
          f"{t_wpi / t_caster:.0f}x (caster3, one steer state), "
          f"{t_wpi / t_caster_rows:.0f}x (caster3, a steer row per twist); target >= 100x")

    # Same numbers: wpimath's module speed / wheel radius and angle are our wheel rate and steer.
    ours = swerve.inverse(tw[:100])
    for i, (vx, vy, wz) in enumerate(rows[:100]):
        for m, s in enumerate(kin.toSwerveModuleStates(ChassisSpeeds(vx, vy, wz))):
            assert abs(s.speed / 0.05 - ours["wheel_rates"][i, m]) < 1e-9
            da = math.remainder(s.angle.radians() - ours["steer_angles"][i, m], 2 * math.pi)
            assert abs(da) < 1e-9 or abs(s.speed) < 1e-12
    print("first 100 rows agree with wpimath to 1e-9")


if __name__ == "__main__":
    main()
