"""Errors: wrong shapes and dtypes name the argument and the expected shape; bad robot files
raise ValueError with the CLI's message."""

import numpy as np
import pytest

import omnikin


@pytest.fixture
def caster():
    return omnikin.Robot("caster3")


@pytest.mark.parametrize(
    "bad, shape",
    [(np.zeros((4, 2)), "(4, 2)"), (np.zeros(4), "(4,)"), (np.zeros((2, 3, 1)), "(2, 3, 1)")],
)
def test_inverse_wrong_shape(caster, bad, shape):
    with pytest.raises(ValueError, match=r"twists: expected shape \(N, 3\) or \(3,\).*got " + shape.replace("(", r"\(").replace(")", r"\)")):
        caster.inverse(bad)


def test_inverse_wrong_dtype(caster):
    # Integer and float32 arrays convert as numpy.asarray(x, float64) does (docs/python.md).
    twists = np.array([[1, 0, 0], [0, 1, 2]])
    want = caster.inverse(twists.astype(np.float64))["wheel_rates"]
    for t in [twists, twists.astype(np.float32)]:
        np.testing.assert_array_equal(caster.inverse(t)["wheel_rates"], want)
    # A dtype that would lose data (the imaginary part) is refused by name.
    with pytest.raises(ValueError, match="twists: expected a float64 array.*got dtype complex128"):
        caster.inverse(np.zeros((3, 3), dtype=np.complex128))
    with pytest.raises(ValueError, match="twists"):
        caster.inverse([["a", "b", "c"]])


def test_forward_wrong_shape_and_missing_steer_rates(caster):
    with pytest.raises(ValueError, match=r"wheel_rates: expected shape \(N, 3\)"):
        caster.forward(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="caster3 needs all 6 motor rates"):
        caster.forward(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="steer: 5 rows, but wheel_rates has 2"):
        caster.forward(np.zeros((2, 3)), steer=np.zeros((5, 3)), steer_rates=np.zeros(3))


def test_steer_refused_without_steering(cli):
    kiwi = omnikin.Robot("kiwi")
    with pytest.raises(ValueError, match="steer applies only to kinds with steering"):
        kiwi.inverse(np.zeros(3), steer=np.zeros(3))
    with pytest.raises(ValueError, match="shell_spin applies only to sphere-omni and ballbot"):
        kiwi.inverse(np.zeros(3), shell_spin=1.0)
    msg = cli.error("torques", "caster3", "--wrench", "1,2,3")
    with pytest.raises(ValueError) as e:
        omnikin.Robot("caster3").torques(wrench=[1.0, 2.0, 3.0])
    assert str(e.value) == msg


def test_non_finite_row_is_named(caster):
    tw = np.zeros((5, 3))
    tw[3, 1] = np.nan
    with pytest.raises(ValueError, match="twists row 3: vy must be finite"):
        caster.inverse(tw)


def test_unknown_robot_has_the_cli_message(cli):
    msg = cli.error("check", "no-such-robot")
    with pytest.raises(ValueError) as e:
        omnikin.Robot("no-such-robot")
    assert str(e.value) == msg


BAD_FILES = {
    "negative radius": None,  # built from the kiwi preset below
    "syntax": 'kind = "omni"\n[geometry\n',
    "unknown kind": 'kind = "hovercraft"\n',
}


@pytest.mark.parametrize("what", list(BAD_FILES))
def test_bad_robot_file_has_the_cli_message(cli, tmp_path, what):
    text = BAD_FILES[what]
    if what == "negative radius":
        # The kiwi preset with one bad value: the message names the field and the rule.
        text = "\n".join(
            "radius = -0.05" if line.startswith("radius") else line
            for line in omnikin.Robot("kiwi").toml.splitlines()
        )
    f = tmp_path / "bad.toml"
    f.write_text(text)
    msg = cli.error("check", str(f))
    with pytest.raises(ValueError) as e:
        omnikin.Robot(str(f))
    assert str(e.value) == msg


def test_plan_option_errors():
    with pytest.raises(ValueError, match='unknown option "sped"'):
        omnikin.plan("kiwi", "square", sped=0.1)
    with pytest.raises(ValueError, match="speed: must be > 0"):
        omnikin.plan("kiwi", "square", speed=-1.0)
    with pytest.raises(ValueError, match="circle needs omega"):
        omnikin.plan("kiwi", "circle")
    with pytest.raises(ValueError, match="too fast for"):
        omnikin.plan("kiwi", "circle", omega=50.0)
    with pytest.raises(ValueError, match="kind \"triangle\""):
        omnikin.plan("kiwi", "triangle")
