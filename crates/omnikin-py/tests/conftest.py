"""Shared fixtures: the `omnikin` CLI that the Python results are compared with.

The binary is `$OMNIKIN_BIN`, or `target/debug/omnikin` of this workspace (`cargo build -p
omnikin-cli`); the comparison tests fail, not skip, without it.
"""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
PRESETS = ["sphere-omni", "ballbot", "caster3", "kiwi", "x-drive", "mecanum", "swerve4"]


def num(x: float) -> str:
    """A float as the CLI reads it back exactly (Python's repr is the shortest round trip)."""
    return repr(float(x))


def nums(xs) -> str:
    return ",".join(num(x) for x in xs)


class Cli:
    def __init__(self, path: pathlib.Path):
        self.path = path

    def run(self, *args: str, check: bool = True) -> subprocess.CompletedProcess:
        p = subprocess.run(
            [str(self.path), *map(str, args)], capture_output=True, text=True, cwd=ROOT
        )
        if check and p.returncode != 0:
            raise AssertionError(f"omnikin {' '.join(map(str, args))} failed: {p.stderr}")
        return p

    def json(self, *args: str) -> dict:
        return json.loads(self.run(*args, "--json").stdout)

    def error(self, *args: str) -> str:
        """The message of a failing command (stderr without `error: `)."""
        p = self.run(*args, check=False)
        assert p.returncode != 0, f"omnikin {' '.join(args)} succeeded"
        line = p.stderr.strip().splitlines()[-1]
        assert line.startswith("error: "), p.stderr
        return line[len("error: "):]


@pytest.fixture(scope="session")
def cli() -> Cli:
    path = pathlib.Path(os.environ.get("OMNIKIN_BIN", ROOT / "target" / "debug" / "omnikin"))
    if not path.exists():
        pytest.fail(f"{path} not found: build it with `cargo build -p omnikin-cli` or set OMNIKIN_BIN")
    return Cli(path)


def read_csv(path) -> dict:
    """A CSV file of numbers as a dict of columns."""
    import numpy as np

    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {c: data[:, i] for i, c in enumerate(header)}
