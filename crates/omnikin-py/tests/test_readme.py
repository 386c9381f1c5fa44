"""The README's Python example runs as written (in a temporary directory, no display)."""

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
    assert blocks, "no python block in the README's Python section"
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    for code in blocks:
        exec(compile(code, "README.md", "exec"), scope)
    assert scope["rates"]["wheel_rates"].shape == (1000, 3)
    assert scope["run"]["metrics"]["max_deviation_m"] < 1e-3
    assert os.path.getsize(tmp_path / "circle.png") > 0
