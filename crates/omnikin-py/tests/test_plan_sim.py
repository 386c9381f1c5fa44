"""plan, simulate and evaluate against `omnikin plan/simulate/evaluate` on the same inputs:
the same columns as the CSV files, equal to 1e-12, and the same metrics.json."""

import json
import pathlib

import numpy as np
import pytest

import omnikin
from conftest import ROOT, nums, read_csv

TOL = 1e-12


def assert_table(got: dict, want: dict):
    assert list(got) == list(want)
    for c in want:
        assert got[c].shape == want[c].shape, c
        np.testing.assert_allclose(got[c], want[c], rtol=0, atol=TOL, err_msg=c)


def assert_metrics(got, want, tol=TOL):
    if isinstance(want, dict):
        assert set(got) == set(want)
        for k in want:
            assert_metrics(got[k], want[k], tol)
    elif isinstance(want, list):
        assert len(got) == len(want)
        for a, b in zip(got, want):
            assert_metrics(a, b, tol)
    elif isinstance(want, float):
        assert abs(got - want) <= tol * max(1.0, abs(want)), (got, want)
    else:
        assert got == want


CASES = [
    ("kiwi", "circle", {"omega": 1.0, "radius": 0.3, "ramp": 0.5}),
    ("caster3", "circle", {"omega": -0.8, "face_motion": True, "rate": 50.0}),
    ("swerve4", "square", {"speed": 0.3, "side": 0.5}),
    ("sphere-omni", "square", {"profile": "s-curve"}),
    ("mecanum", "square", {"no_retime": True, "ramp_fraction": 0.1}),
    ("caster3", "square", {"initial_steer": [0.1, 0.2, -0.3]}),
    # The ballbot's lean limit lowers the acceleration (1.6 -> 0.978 m/s²) in both front ends;
    # before it moved into omnikin-plan, Python's plan asked 1.6 m/s².
    ("ballbot", "square", {"side": 0.5, "speed": 0.2}),
]


def flags(options: dict) -> list:
    out = []
    for k, v in options.items():
        flag = "--" + k.replace("_", "-")
        if v is True:
            out.append(flag)
        elif isinstance(v, list):
            out += [flag, nums(v)]
        else:
            out += [flag, repr(v) if isinstance(v, float) else str(v)]
    return out


@pytest.mark.parametrize("robot, kind, options", CASES)
def test_plan_matches_cli(cli, tmp_path, robot, kind, options):
    got = omnikin.plan(robot, kind, **options)
    f = tmp_path / "plan.csv"
    cli.run("plan", kind, "--robot", robot, *flags(options), "--out", f)
    assert_table(got, read_csv(f))


@pytest.mark.parametrize("law", ["constant", "tangent", "waypoints"])
def test_waypoints_plan_matches_cli(cli, tmp_path, law):
    wp = tmp_path / "wp.csv"
    wp.write_text("x,y,heading\n0,0,0\n0.5,0,0.5\n0.5,0.4,1.0\n0,0.6,1.5\n")
    options = {"file": str(wp), "heading_law": law, "path": "spline", "max_speed": 0.3}
    got = omnikin.plan("x-drive", "waypoints", **options)
    f = tmp_path / "plan.csv"
    cli.run("plan", "waypoints", wp, "--robot", "x-drive", "--heading-law", law,
            "--path", "spline", "--max-speed", "0.3", "--out", f)
    assert_table(got, read_csv(f))
    got = omnikin.plan("kiwi", "waypoints", file=str(wp), corners="fillet", time_optimal=True)
    cli.run("plan", "waypoints", wp, "--robot", "kiwi", "--corners", "fillet",
            "--time-optimal", "--out", f, "--force")
    assert_table(got, read_csv(f))


@pytest.mark.parametrize("robot, disturbances", [("kiwi", None), ("caster3", "noisy"), ("swerve4", "noisy")])
def test_simulate_matches_cli(cli, tmp_path, robot, disturbances):
    p = omnikin.plan(robot, "circle", omega=1.0, ramp=0.5)
    plan_csv = tmp_path / "plan.csv"
    cli.run("plan", "circle", "--robot", robot, "--omega", "1", "--ramp", "0.5", "--out", plan_csv)
    extra = []
    if disturbances:
        prof = pathlib_profile(tmp_path)
        extra = ["--disturbances", prof]
    out = tmp_path / "sim"
    cli.run("simulate", plan_csv, "--robot", robot, "--trials", "4", "--seed", "7",
            "--threads", "2", *extra, "--out", out)
    kw = {"disturbances": extra[1]} if extra else {}
    for plan_arg in (p, plan_csv):
        got = omnikin.simulate(robot, plan_arg, trials=4, seed=7, threads=1, **kw)
        assert_table(got["trials"], read_csv(out / "trials.csv"))
        assert_table(got["mean"], read_csv(out / "mean.csv"))
        want = json.loads((out / "metrics.json").read_text())
        for m in (got["metrics"], want):
            m["simulation"].pop("plan")
        assert_metrics(got["metrics"], want)


def pathlib_profile(tmp_path):
    """A disturbance profile with noise in every part the plant simulates."""
    f = tmp_path / "profile.toml"
    f.write_text(
        "[wheel_motor]\nradius_error_std = 0.01\n[floor]\nrel_std = 0.03\ncorr_time = 0.3\n"
        "[tracking]\nnoise_std = 0.001\n"
    )
    return str(f)


def test_simulate_is_the_same_on_any_number_of_threads():
    p = omnikin.plan("kiwi", "square", speed=0.2)
    a = omnikin.simulate("kiwi", p, trials=3, seed=2, threads=1)
    b = omnikin.simulate("kiwi", p, trials=3, seed=2, threads=2)
    assert a["metrics"] == b["metrics"]
    for k in a["trials"]:
        np.testing.assert_array_equal(a["trials"][k], b["trials"][k])


def test_evaluate_matches_cli(cli, tmp_path):
    p = omnikin.plan("kiwi", "circle", omega=1.0, ramp=0.5)
    plan_csv = tmp_path / "plan.csv"
    cli.run("plan", "circle", "--robot", "kiwi", "--omega", "1", "--ramp", "0.5", "--out", plan_csv)
    tracks = []
    rng = np.random.default_rng(4)
    for i in range(2):
        f = tmp_path / f"track{i}.csv"
        x = p["x"] + rng.normal(0, 0.002, p["x"].shape) + 0.01 * i
        y = p["y"] + rng.normal(0, 0.002, p["y"].shape)
        np.savetxt(f, np.column_stack([p["t"], x, y]), delimiter=",", header="t,x,y", comments="")
        tracks.append(str(f))
    out = tmp_path / "eval"
    cli.run("evaluate", "--plan", plan_csv, *tracks, "--tracking-offset", "0.01,-0.02", "--out", out)
    got = omnikin.evaluate(plan_csv, tracks, tracking_offset=[0.01, -0.02])
    assert_table(got["runs"], read_csv(out / "runs.csv"))
    assert_table(got["mean"], read_csv(out / "mean.csv"))
    assert_metrics(got["metrics"], json.loads((out / "metrics.json").read_text()))
    # The plan from omnikin.plan gives the same numbers (its CSV is written exactly).
    again = omnikin.evaluate(p, tracks, tracking_offset=[0.01, -0.02])
    assert again["metrics"]["max_deviation_m"] == got["metrics"]["max_deviation_m"]
    # Runs as a pathlib.Path, a dict of columns and an (n, 3) array give the same numbers.
    cols = read_csv(tracks[1])
    array = np.column_stack([cols["t"], cols["x"], cols["y"]])
    for second in [cols, array]:
        mixed = omnikin.evaluate(p, [pathlib.Path(tracks[0]), second], tracking_offset=[0.01, -0.02])
        for k in ["max_deviation_m", "rms_deviation_m", "end_point_error_m"]:
            assert mixed["metrics"][k] == got["metrics"][k], k
    # simulate's trials table is one run per trial.
    sim = omnikin.simulate("kiwi", p, trials=3, seed=2, threads=1)
    assert omnikin.evaluate(p, sim["trials"])["metrics"]["runs"] == 3


MAP = "examples/maps/cluttered.toml"


def test_goal_plan_matches_cli(cli, tmp_path):
    # issue 40: the same request as `omnikin plan goal` gives the same plan, and it ends at
    # the goal with the goal's heading.
    options = {"map": str(ROOT / MAP), "start": [0.5, 0.5], "goal": [9.5, 9.5, 1.5],
               "footprint_radius": 0.2, "max_speed": 0.3}
    got = omnikin.plan("kiwi", "goal", **options)
    f = tmp_path / "plan.csv"
    cli.run("plan", "goal", "--robot", "kiwi", "--map", MAP, "--from", "0.5,0.5",
            "--to", "9.5,9.5,1.5", "--footprint-radius", "0.2", "--max-speed", "0.3", "--out", f)
    assert_table(got, read_csv(f))
    assert abs(got["x"][-1] - 9.5) < 1e-6 and abs(got["heading"][-1] - 1.5) < 1e-6


def test_goal_errors_name_the_map_line():
    with pytest.raises(ValueError, match=r"cluttered.toml:6: .*goal .*inside"):
        omnikin.plan("sphere-omni", "goal", map=str(ROOT / MAP), start=[0.5, 0.5],
                     goal=[4.65, 8.17])
    with pytest.raises(ValueError, match="start: expected"):
        omnikin.plan("sphere-omni", "goal", map=str(ROOT / MAP), start=[0.5], goal=[1, 1])


def test_start_velocity_matches_cli(cli, tmp_path):
    # A plan that starts moving: the same as `--start-velocity`, its first sample at the given
    # velocity; the goal plan leaves the start along it.
    wp = tmp_path / "wp.csv"
    wp.write_text("x,y\n0,0\n1,0\n1.5,0.8\n")
    got = omnikin.plan("kiwi", "waypoints", file=str(wp), corners="fillet", fillet_radius=0.3,
                       time_optimal=True, max_speed=1.0, start_velocity=[0.5, 0.0])
    f = tmp_path / "plan.csv"
    cli.run("plan", "waypoints", wp, "--robot", "kiwi", "--corners", "fillet",
            "--fillet-radius", "0.3", "--time-optimal", "--max-speed", "1",
            "--start-velocity", "0.5,0", "--out", f)
    assert_table(got, read_csv(f))
    assert abs(got["vx"][0] - 0.5) < 1e-9 and abs(got["vy"][0]) < 1e-9
    options = {"map": str(ROOT / MAP), "start": [0.5, 0.5], "goal": [9.5, 9.5, 1.5],
               "footprint_radius": 0.2, "max_speed": 0.3, "start_velocity": [0.2, 0.1, 0.05]}
    got = omnikin.plan("kiwi", "goal", **options)
    g = tmp_path / "goal.csv"
    cli.run("plan", "goal", "--robot", "kiwi", "--map", MAP, "--from", "0.5,0.5",
            "--to", "9.5,9.5,1.5", "--footprint-radius", "0.2", "--max-speed", "0.3",
            "--start-velocity", "0.2,0.1,0.05", "--out", g)
    assert_table(got, read_csv(g))
    for col, want in (("vx", 0.2), ("vy", 0.1), ("yaw_rate", 0.05)):
        assert abs(got[col][0] - want) < 1e-9, (col, got[col][0])
    with pytest.raises(ValueError, match="above the 0.300000 m/s that max speed allows"):
        omnikin.plan("kiwi", "goal", **{**options, "start_velocity": [0.4, 0.0]})
    with pytest.raises(ValueError, match="unknown|start_velocity"):
        omnikin.plan("kiwi", "square", start_velocity=[0.1, 0.0])
