"""The Python examples of the README and of docs/python.md run as written (in a temporary
directory, no display)."""

import os
import re

from conftest import ROOT


def readme_python_blocks():
    text = (ROOT / "README.md").read_text()
    section = text.split("\n## Python\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def test_readme_example_runs(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    blocks = readme_python_blocks()
    if not blocks:
        import pytest

        pytest.skip("the README's Python section has no example (docs/python.md has it)")
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    for code in blocks:
        exec(compile(code, "README.md", "exec"), scope)
    assert scope["rates"]["wheel_rates"].shape == (1000, 3)
    assert scope["run"]["metrics"]["max_deviation_m"] < 1e-3
    assert os.path.getsize(tmp_path / "circle.png") > 0


def test_docs_python_example_runs(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    text = (ROOT / "docs" / "python.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "no python block in docs/python.md"
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    for code in blocks:
        exec(compile(code, "docs/python.md", "exec"), scope)
    assert scope["run"]["metrics"]["radius_ratio"] > 0.95
    assert scope["odo"]["summary"]["fixes"]["accepted"] > 0
    assert not scope["pushed"]["metrics"]["fallen"]
    assert os.path.getsize(tmp_path / "python-circle.png") > 0
    ident = scope["ident"]
    v, s = ident["estimates"]["wheels[2].radius_scale"], ident["sigma"]["wheels[2].radius_scale"]
    assert 0 < s < 0.01 and abs(v - 1.03) <= 3 * s, (v, s)
    assert "identified" in (tmp_path / "kiwi-identified.toml").read_text()
