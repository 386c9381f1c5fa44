"""Robot properties and the vectorised kinematics against `omnikin inverse/forward/torques
--json` on the same inputs (to 1e-12), and the round trip forward(inverse(twist)) for every
preset."""

import numpy as np
import pytest

import omnikin
from conftest import PRESETS, num, nums

TOL = 1e-12


def twists(n=4, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.4, 0.4, size=(n, 3))


def steer_for(robot, n, seed=1):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.2, 1.2, size=(n, robot.wheels))


@pytest.mark.parametrize("preset", PRESETS)
def test_properties_match_check(cli, preset):
    r = omnikin.Robot(preset)
    j = cli.json("check", preset)
    assert r.name == j["name"]
    assert r.kind == j["kind"]
    assert r.wheels == j["wheels"]
    assert r.motors == j["motors"]
    assert r.limits == j["limits"]
    assert r.description["kind"] == j["kind"]
    assert r.source == j["source"]


@pytest.mark.parametrize("preset", PRESETS)
def test_inverse_matches_cli(cli, preset):
    r = omnikin.Robot(preset)
    tw = twists()
    steer = steer_for(r, len(tw)) if r.steerable else None
    spin = 0.3 if r.kind in ("sphere-omni", "ballbot") else None
    out = r.inverse(tw, steer=steer, shell_spin=spin)
    for i, t in enumerate(tw):
        args = ["inverse", preset, "--vx", num(t[0]), "--vy", num(t[1]), "--yaw-rate", num(t[2])]
        if steer is not None:
            args += ["--steer", nums(steer[i])]
        if spin is not None:
            args += ["--shell-spin", num(spin)]
        j = cli.json(*args)
        assert set(out) == set(j)
        for key, v in j.items():
            assert out[key].shape == (len(tw), r.wheels)
            np.testing.assert_allclose(out[key][i], v, rtol=0, atol=TOL)


@pytest.mark.parametrize("preset", PRESETS)
def test_single_twist_gives_one_row(preset):
    r = omnikin.Robot(preset)
    tw = twists(2)
    many = r.inverse(tw)
    one = r.inverse(tw[1])
    for key in many:
        assert one[key].shape == (r.wheels,)
        np.testing.assert_array_equal(one[key], many[key][1])
    # Lists are arrays too.
    np.testing.assert_array_equal(r.inverse(list(tw[1]))["wheel_rates"], one["wheel_rates"])


@pytest.mark.parametrize("preset", PRESETS)
def test_forward_matches_cli(cli, preset):
    r = omnikin.Robot(preset)
    rng = np.random.default_rng(3)
    n = 4
    w = rng.uniform(-5, 5, size=(n, r.wheels))
    steer = steer_for(r, n) if r.steerable else None
    rates = rng.uniform(-1, 1, size=(n, r.wheels)) if r.kind == "caster3" else None
    spin = -0.2 if r.kind in ("sphere-omni", "ballbot") else None
    has_slip = spin is None
    res = r.forward(w, steer=steer, steer_rates=rates, shell_spin=spin, slip=has_slip)
    tw, slip = res if has_slip else (res, None)
    assert tw.shape == (n, 3)
    for i in range(n):
        args = ["forward", preset, "--wheel-rates", nums(w[i])]
        if steer is not None:
            args += ["--steer", nums(steer[i])]
        if rates is not None:
            args += ["--steer-rates", nums(rates[i])]
        if spin is not None:
            args += ["--shell-spin", num(spin)]
        j = cli.json(*args)
        np.testing.assert_allclose(tw[i], [j["vx"], j["vy"], j["yaw_rate"]], rtol=0, atol=TOL)
        if has_slip:
            assert abs(slip[i] - j["slip_residual"]) <= TOL


@pytest.mark.parametrize("preset", PRESETS)
def test_round_trip_inverse_forward(preset):
    """forward(inverse(twist)) is the twist, for every preset (at random steer angles for the
    caster, whose forward needs the steer angles and rates the inverse gave)."""
    r = omnikin.Robot(preset)
    tw = twists(200, seed=5)
    steer = steer_for(r, len(tw), seed=6) if r.kind == "caster3" else None
    inv = r.inverse(tw, steer=steer)
    if r.kind == "caster3":
        back = r.forward(inv["wheel_rates"], steer=steer, steer_rates=inv["steer_rates"])
    elif r.kind == "swerve":
        back = r.forward(inv["wheel_rates"], steer=inv["steer_angles"])
    else:
        back = r.forward(inv["wheel_rates"])
    np.testing.assert_allclose(back, tw, rtol=0, atol=1e-9)


def test_steer_broadcasts_one_row():
    r = omnikin.Robot("caster3")
    tw = twists(3)
    g = np.array([0.1, -0.2, 0.3])
    a = r.inverse(tw, steer=g)
    b = r.inverse(tw, steer=np.tile(g, (3, 1)))
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])


def test_torques_match_cli(cli):
    rng = np.random.default_rng(9)
    b = omnikin.Robot("ballbot")
    g = rng.uniform(-2, 2, size=(3, 3))
    out = b.torques(model=g, yaw=0.4)["wheel_torques"]
    back = b.torques(wheels=out, yaw=0.4)["model_torques"]
    for i in range(3):
        j = cli.json("torques", "ballbot", "--model", nums(g[i]), "--yaw", num(0.4))
        np.testing.assert_allclose(out[i], j["wheel_torques"], rtol=0, atol=TOL)
        j = cli.json("torques", "ballbot", "--wheels", nums(out[i]), "--yaw", num(0.4))
        np.testing.assert_allclose(back[i], j["model_torques"], rtol=0, atol=TOL)
    np.testing.assert_allclose(back, g, rtol=0, atol=1e-9)
    for preset in ["kiwi", "mecanum", "swerve4"]:
        r = omnikin.Robot(preset)
        wr = rng.uniform(-5, 5, size=(2, 3))
        steer = steer_for(r, 2) if r.steerable else None
        out = r.torques(wrench=wr, steer=steer)
        wheels = rng.uniform(-1, 1, size=(2, r.wheels))
        gen = r.torques(wheels=wheels, steer=steer)
        (gkey,) = gen
        for i in range(2):
            extra = ["--steer", nums(steer[i])] if steer is not None else []
            j = cli.json("torques", preset, "--wrench", nums(wr[i]), *extra)
            np.testing.assert_allclose(out["wheel_torques"][i], j["wheel_torques"], rtol=0, atol=TOL)
            j = cli.json("torques", preset, "--wheels", nums(wheels[i]), *extra)
            assert set(j) == {gkey}
            np.testing.assert_allclose(gen[gkey][i], j[gkey], rtol=0, atol=TOL)


def test_large_arrays_are_computed_in_parallel_chunks_identically():
    """More rows than one chunk (the parallel path) give the rows of the serial path."""
    r = omnikin.Robot("swerve4")
    tw = twists(20000, seed=11)
    big = r.inverse(tw)
    small = r.inverse(tw[-5:])
    for k in big:
        np.testing.assert_array_equal(big[k][-5:], small[k])


def test_caster3_one_steer_state_is_the_per_row_inverse_exactly():
    """One steer row (or none: zeros) takes the core's fixed-steer path
    (Caster3::robot_frame_inverse); it equals the per-row inverse bit for bit, errors included,
    on more rows than one parallel chunk."""
    r = omnikin.Robot("caster3")
    rng = np.random.default_rng(11)
    tw = rng.uniform(-2.0, 2.0, size=(20_000, 3))
    tw[::97] *= 1e3
    for g in (np.array([0.3, -1.2, 2.9]), None):
        per_row = np.tile(np.zeros(3) if g is None else g, (len(tw), 1))
        a, b = r.inverse(tw, steer=g), r.inverse(tw, steer=per_row)
        assert list(a) == list(b) == ["wheel_rates", "steer_rates"]
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])
        one = r.inverse(tw[5], steer=g)
        np.testing.assert_array_equal(one["wheel_rates"], a["wheel_rates"][5])
    bad = tw.copy()
    bad[12_345, 1] = np.nan
    bad[17_000, 0] = np.inf
    msgs = []
    for g in (np.zeros(3), np.zeros((len(tw), 3))):
        with pytest.raises(ValueError) as e:
            r.inverse(bad, steer=g)
        msgs.append(str(e.value))
    assert msgs[0] == msgs[1] and msgs[0].startswith("twists row 12345: ")
    with pytest.raises(ValueError) as e1:
        r.inverse(tw, steer=[0.0, np.nan, 0.0])
    with pytest.raises(ValueError) as e2:
        r.inverse(tw, steer=np.tile([0.0, np.nan, 0.0], (len(tw), 1)))
    assert str(e1.value) == str(e2.value)
