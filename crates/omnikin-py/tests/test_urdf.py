"""`omnikin urdf` read by an independent URDF parser (yourdfpy, the forward kinematics of
robot_state_publisher's kind): for every preset, each wheel joint's centre and spin axis in
base_link, computed here from the robot file with the formulas of conventions.md and the
seed digest, and the wheel's rolling direction for a positive rate (issue 39)."""

import math
import tomllib

import numpy as np
import pytest
import yourdfpy

from conftest import PRESETS, ROOT

Z = np.array([0.0, 0.0, 1.0])


def load(cli, tmp_path, robot):
    out = tmp_path / f"{robot}.urdf"
    cli.run("urdf", robot, "--out", out)
    return yourdfpy.URDF.load(str(out), build_scene_graph=True, load_meshes=False)


def frame(urdf, joint):
    """Centre and axis of `joint` in base_link at the current configuration."""
    j = urdf.joint_map[joint]
    t = urdf.get_transform(j.child, "base_link")
    return t[:3, 3], t[:3, :3] @ np.asarray(j.axis, dtype=float)


def rolling_direction(axis):
    """Where a wheel's centre moves on the floor for a positive spin about `axis`: the rim's
    floor point moves by ω a × (−r ẑ) relative to the centre, so the centre by r (a × ẑ)."""
    return np.cross(axis, Z)


def expected(robot):
    """[(joint, centre, axis)] from the robot file, written from conventions.md."""
    f = tomllib.loads((ROOT / "robots" / f"{robot}.toml").read_text())
    g, kind = f.get("geometry", {}), f["kind"]
    rows = []
    if kind == "omni":
        for i, w in enumerate(g["wheels"]):
            a = math.radians(w["drive_angle_deg"])
            d = np.array([math.cos(a), math.sin(a), 0.0])
            # a positive rate pushes the robot along d: the axis whose rolling direction is d
            axis = np.cross(Z, d)
            assert np.allclose(rolling_direction(axis), d)
            rows.append((f"wheel_{i + 1}", np.array([*w["position"], w["radius"]]), axis))
    elif kind == "swerve":
        for i, m in enumerate(g["modules"]):
            c = np.array([*m["position"], m["wheel_radius"]])
            rows.append((f"steer_{i + 1}", c, Z))
            # steer angle 0: rolling along robot +x
            rows.append((f"wheel_{i + 1}", c, np.cross(Z, [1.0, 0.0, 0.0])))
    elif kind == "caster3":
        big_d, d, r = g["mount_radius"], g["eccentricity"], g["wheel_radius"]
        for i, a in enumerate(g["mount_angles_deg"]):
            b = np.array([math.cos(math.radians(a)), math.sin(math.radians(a)), 0.0])
            rows.append((f"steer_{i + 1}", big_d * b + r * Z, Z))
            # γ = 0: wheel radially outward, O at D + d; v_O = −r φ̇ b (paper 003)
            rows.append((f"wheel_{i + 1}", (big_d + d) * b + r * Z, np.cross(Z, -b)))
    elif kind == "sphere-omni":
        big_r, rw = g["shell_radius"], g["wheel_radius"]
        delta = math.radians(g["tilt_deg"])
        for i, p in enumerate(g["azimuths_deg"]):
            phi = math.radians(p)
            r_i = (big_r - rw) * np.array(
                [math.sin(delta) * math.cos(phi), math.sin(delta) * math.sin(phi), -math.cos(delta)])
            n_i = np.array(
                [math.cos(delta) * math.cos(phi), math.cos(delta) * math.sin(phi), math.sin(delta)])
            rows.append((f"wheel_{i + 1}", big_r * Z + r_i, n_i))
    elif kind == "ballbot":
        rb, rw = g["ball_radius"], g["wheel_radius"]
        al = math.radians(g["zenith_deg"])
        omega = np.array([0.3, -0.7, 0.2])
        for i, bdeg in enumerate(g["azimuths_deg"]):
            b = math.radians(bdeg)
            n = np.array([math.sin(al) * math.cos(b), math.sin(al) * math.sin(b), math.cos(al)])
            t = np.array([-math.sin(b), math.cos(b), 0.0])
            # the axis is ⊥ n and t; its sign is the one for which equal contact velocities
            # along t give conventions.md's rate law ψ̇ = (R/r)(−cosα cosβ ωx − cosα sinβ ωy + sinα ωz)
            a = np.cross(n, t)
            law = (rb / rw) * (-math.cos(al) * math.cos(b) * omega[0]
                               - math.cos(al) * math.sin(b) * omega[1] + math.sin(al) * omega[2])
            rate = -rb * np.dot(np.cross(omega, n), t) / (rw * np.dot(np.cross(a, n), t))
            if abs(rate + law) < 1e-9:
                a = -a
            rows.append((f"wheel_{i + 1}", rb * Z + (rb + rw) * n, a))
    return rows


@pytest.mark.parametrize("robot", PRESETS)
def test_joints_match_the_robot_file(cli, tmp_path, robot):
    urdf = load(cli, tmp_path, robot)
    rows = expected(robot)
    continuous = sorted(n for n, j in urdf.joint_map.items() if j.type == "continuous")
    assert continuous == sorted(n for n, _, _ in rows)
    for name, centre, axis in rows:
        c, a = frame(urdf, name)
        assert np.allclose(c, centre, atol=1e-12), (name, c, centre)
        assert np.allclose(a, axis, atol=1e-12), (name, a, axis)


@pytest.mark.parametrize("robot", ["swerve4", "caster3"])
def test_a_steer_angle_turns_the_wheel_axis_about_z(cli, tmp_path, robot):
    urdf = load(cli, tmp_path, robot)
    _, a0 = frame(urdf, "wheel_1")
    gamma = 0.7
    urdf.update_cfg({"steer_1": gamma})
    _, a1 = frame(urdf, "wheel_1")
    rz = np.array([[math.cos(gamma), -math.sin(gamma), 0.0],
                   [math.sin(gamma), math.cos(gamma), 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(a1, rz @ a0, atol=1e-12)
