"""The project's lint rules hold: ``ruff check`` with the configuration of pyproject.toml passes.

The rule set ([tool.ruff]) is pycodestyle, pyflakes, import order, bugbear, pyupgrade,
simplify and a complexity ceiling of 15 (numba kernels exempt from the ceiling only); the
import layers are checked apart, by tests/test_layers.py.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _ruff() -> list[str]:
    try:
        from ruff.__main__ import find_ruff_bin
    except ImportError:
        found = shutil.which("ruff")
        if found is None:
            pytest.skip("ruff is not installed: pip install -e '.[test]'")
        return [found]
    return [find_ruff_bin()]


def test_ruff_passes_with_the_project_config():
    run = subprocess.run([*_ruff(), "check", "--no-cache", "src", "tests", "benchmarks", "tools", "build_backend"], cwd=ROOT,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def test_the_config_selects_the_rule_set():
    import tomllib

    lint = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["ruff"]["lint"]
    assert {"E", "F", "W", "I", "B", "UP", "SIM", "C90"} <= set(lint["select"])
    assert lint["mccabe"]["max-complexity"] <= 15
