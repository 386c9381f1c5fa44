"""omnikin.identify against `omnikin identify` on logs the CLI simulated (`plan sysid`, then
`simulate --emit-sensors` with a robot file whose wheel 1 is 2 % smaller): the same
parameters, 1σ, table and robot file as the CLI, the perturbation recovered, dicts of columns
as inputs, and bad input refused naming the argument."""

import json

import numpy as np
import pytest

import omnikin
from conftest import ROOT, read_csv

PLANS = ["along-across", "spin"]
SENSORS = (
    "counts_per_rev = 4096\n[gyro]\nnoise_std = 0.002\nbias = -0.02\nbias_std = 0.0\n"
    "[camera]\nperiod = 0.1\nlatency = 0.0\nnoise_std = 0.003\noutlier_probability = 0.0\n"
    "outlier_distance = 0.5\n"
)


@pytest.fixture(scope="module")
def logs(cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("identify")
    text = (ROOT / "robots" / "kiwi.toml").read_text()
    truth = text.replace("radius = 0.05", "radius = 0.049", 1)
    assert truth != text
    (d / "kiwi-true.toml").write_text(truth)
    (d / "sensors.toml").write_text(SENSORS)
    cli.run("plan", "sysid", "--robot", "kiwi", "--out", d / "plans")
    enc, fixes = [], []
    for p in PLANS:
        cli.run("simulate", d / "plans" / f"{p}.csv", "--robot", d / "kiwi-true.toml",
                "--trials", "1", "--seed", "5", "--emit-sensors", "--sensors", d / "sensors.toml",
                "--out", d / f"sim-{p}")
        enc.append(d / f"sim-{p}" / "sensors" / "trial-000" / "encoders.csv")
        fixes.append(d / f"sim-{p}" / "sensors" / "trial-000" / "fixes.csv")
    return d, enc, fixes


def test_identify_matches_the_cli_and_recovers_the_radius(cli, logs):
    d, enc, fixes = logs
    got = omnikin.identify("kiwi", enc, fixes=fixes)
    out = d / "cli.toml"
    want = cli.json("identify", "--robot", "kiwi", "--out", out,
                    "--encoders", *enc, "--fixes", *fixes)
    assert [p["name"] for p in got["parameters"]] == [p["name"] for p in want["parameters"]]
    for g, w in zip(got["parameters"], want["parameters"]):
        assert g["status"] == w["status"] and g["reason"] == w["reason"], g
        np.testing.assert_allclose([g["value"], g["sigma"]], [w["value"], w["sigma"]],
                                   rtol=1e-12, atol=1e-15, err_msg=g["name"])
    assert got["robot_file"] == out.read_text()
    table = cli.run("identify", "--robot", "kiwi", "--out", d / "cli2.toml",
                    "--encoders", *enc, "--fixes", *fixes).stdout
    assert got["table"] == table
    # The truth: wheel 1's radius 0.049 m of the preset's 0.05, the gyro's bias -0.02 rad/s.
    for name, truth in [("wheels[1].radius_scale", 0.98), ("gyro.bias", -0.02)]:
        v, s = got["estimates"][name], got["sigma"][name]
        assert 0 < s < 0.01 and abs(v - truth) <= 3 * s, (name, v, s)
    assert "wheels[1].radius_scale" in got["table"]
    # Each run explained better than by the prior, down to the camera's noise (3 mm per axis:
    # an RMS length of 3 mm · √2).
    noise = 0.003 * np.sqrt(2.0)
    for r in got["runs"]:
        after = r["position_rms_after_m"]
        assert after < r["position_rms_before_m"] and abs(after - noise) < 0.3 * noise, r


def test_identify_takes_dicts_of_columns(logs):
    d, enc, fixes = logs
    by_path = omnikin.identify("kiwi", enc, fixes=fixes)
    by_dict = omnikin.identify(omnikin.Robot("kiwi"), [read_csv(e) for e in enc],
                               fixes=[read_csv(f) for f in fixes])
    for a, b in zip(by_path["parameters"], by_dict["parameters"]):
        assert a["name"] == b["name"]
        np.testing.assert_allclose(a["value"], b["value"], rtol=1e-9, atol=1e-12)
    assert "encoders[0], encoders[1], fixes[0], fixes[1]" in by_dict["robot_file"]


def test_identify_refuses_a_run_that_does_not_excite_the_geometry(logs):
    # The square alone (along-across) passes the rank test but leaves wheel positions and the
    # radii nearly blind: refused, naming them, as the CLI does.
    d, enc, fixes = logs
    with pytest.raises(ValueError, match=r"not enough excitation: .*wheels\[1\]\.position\.x"):
        omnikin.identify("kiwi", read_csv(enc[0]), fixes=read_csv(fixes[0]))


def test_identify_refuses_bad_input_naming_it(logs):
    d, enc, fixes = logs
    with pytest.raises(ValueError, match=r"fixes: 1 files for 2 encoder logs"):
        omnikin.identify("kiwi", enc, fixes=fixes[:1])
    with pytest.raises(ValueError, match="fixes or tracked, not both"):
        omnikin.identify("kiwi", enc, fixes=fixes, tracked=fixes)
    with pytest.raises(ValueError, match="a reference per run"):
        omnikin.identify("kiwi", enc)
    columns = read_csv(enc[0])
    del columns["q3"]
    with pytest.raises(ValueError, match=r"encoders\[0\].*q3"):
        omnikin.identify("kiwi", columns, fixes=fixes[0])
