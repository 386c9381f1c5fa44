"""pose_error against `omnikin evaluate --truth` on the README's odometry example (the same
figures to 1e-12, fused 5.0 mm against 10.0 mm for the wheels alone); the same result from a
path, a pathlib.Path, a dict, a DataFrame and an array; per-trial runs from simulate's
output; the namespace and where warnings point."""

import pathlib
import warnings

import numpy as np
import pytest

import omnikin
from conftest import ROOT, read_csv

EXAMPLES = ROOT / "examples"
TRUTH = EXAMPLES / "logs" / "kiwi-truth.csv"


@pytest.fixture(scope="module")
def estimates(cli, tmp_path_factory):
    """The example's fused estimate and the wheels alone, written by the CLI."""
    d = tmp_path_factory.mktemp("pose_error")
    base = ["odometry", "--robot", "kiwi", EXAMPLES / "logs" / "kiwi-encoders.csv",
            "--initial-pose", "0,0,0"]
    cli.run(*base, "--fixes", EXAMPLES / "logs" / "kiwi-fixes.csv", "--out", d / "fused.csv")
    cli.run(*base, "--out", d / "wheels.csv")
    return d / "fused.csv", d / "wheels.csv"


def test_pose_error_matches_the_cli_and_the_hand_figures(cli, estimates):
    fused, wheels = estimates
    got = omnikin.pose_error(TRUTH, [fused, wheels])  # pathlib.Path, as str would be
    want = cli.json("evaluate", "--truth", TRUTH, fused, wheels)
    assert [r["name"] for r in got["runs"]] == [str(fused), str(wheels)]
    for g, w in zip(got["runs"] + [got["overall"]], want["runs"] + [want["overall"]]):
        for key in ["ate_m", "heading_error_rad", "rpe_translation_m", "rpe_rotation_rad"]:
            for stat in ["count", "rms", "mean", "median", "max"]:
                assert g[key][stat] == pytest.approx(w[key][stat], rel=1e-12, abs=1e-15)
    assert round(got["runs"][0]["ate_m"]["rms"] * 1e3, 1) == 5.0
    assert round(got["runs"][1]["ate_m"]["rms"] * 1e3, 1) == 10.0
    se2 = omnikin.pose_error(str(TRUTH), str(fused), align="se2")
    assert se2["runs"][0]["ate_m"]["rms"] < got["runs"][0]["ate_m"]["rms"]


def test_dicts_dataframes_and_arrays_give_the_path_result(estimates):
    pd = pytest.importorskip("pandas")
    fused = estimates[0]
    want = omnikin.pose_error(TRUTH, fused)["runs"][0]
    table = read_csv(fused)
    array = np.column_stack([table[c] for c in ["t", "x", "y", "heading"]])
    # A list is several estimates: one as nested lists is a list of one.
    for est in [table, pd.DataFrame(table), array, [array.tolist()]]:
        got = omnikin.pose_error(read_csv(TRUTH), est)["runs"][0]
        assert got["ate_m"] == want["ate_m"]
        assert got["rpe_rotation_rad"] == want["rpe_rotation_rad"]


def test_int64_and_float32_inputs_are_converted_and_a_wrong_shape_names_the_right_one():
    # Truth on x = t (int64), the estimate 0.5 m to the side (float32: 0.5 is exact).
    truth = np.array([[0, 0, 0], [1, 1, 0], [2, 2, 0], [3, 3, 0]])
    est = np.array([[0.5, 0.5, 0.5], [1.5, 1.5, 0.5], [2.5, 2.5, 0.5]], dtype=np.float32)
    r = omnikin.pose_error(truth, est)["runs"][0]
    assert r["ate_m"]["max"] == 0.5 and r["ate_m"]["count"] == 3
    assert r["rpe_translation_m"] is None  # no headings
    with pytest.raises(ValueError, match=r"shape \(n, 3\) or \(n, 4\).*got \(4, 2\)"):
        omnikin.pose_error(truth[:, :2], est)
    with pytest.raises(ValueError, match="do not overlap"):
        omnikin.pose_error(truth, est + np.float32(10))
    with pytest.raises(ValueError, match="missing y"):
        omnikin.pose_error({"t": [0, 1], "x": [0, 1]}, est)


def test_simulate_output_is_scored_per_trial():
    plan = omnikin.plan("kiwi", "circle", omega=1.0)
    sim = omnikin.simulate("kiwi", plan, trials=3, seed=2, threads=1)
    got = omnikin.pose_error(plan, sim["trials"])
    assert [r["name"] for r in got["runs"]] == [f"estimates trial {k}" for k in range(3)]
    trial = sim["trials"]["trial"]
    for k, run in enumerate(got["runs"]):
        rows = {c: sim["trials"][c][trial == k] for c in ["t", "x", "y", "heading"]}
        assert run["ate_m"] == omnikin.pose_error(plan, rows)["runs"][0]["ate_m"]
    assert got["overall"]["samples"] == sum(r["samples"] for r in got["runs"])


def test_the_namespace_is_the_public_api():
    names = set(dir(omnikin))
    assert names == set(omnikin.__all__)
    assert "pose_error" in names
    assert not names & {"np", "os", "json", "Any", "Dict", "Optional", "Union", "Sequence"}


def test_warnings_point_at_the_callers_line():
    logs = EXAMPLES / "logs"
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        omnikin.odometry("kiwi", logs / "kiwi-encoders.csv", fixes=logs / "kiwi-fixes.csv",
                         initial_pose=(0, 0, 0))
    outliers = [x for x in w if "outlier" in str(x.message)]
    assert len(outliers) == 2
    assert all(pathlib.Path(x.filename).resolve() == pathlib.Path(__file__).resolve()
               for x in outliers), [x.filename for x in outliers]
