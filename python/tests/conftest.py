"""Shared pieces of the Python module's tests (run by ctest from the repository root, label
`python`, with PYTHONPATH at the build's python/ folder: python/CMakeLists.txt)."""

import json
import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def cli_binary() -> pathlib.Path:
    """The CLI of the same build (ctest sets AUTONOMSIM_BIN_DIR)."""
    return pathlib.Path(os.environ.get("AUTONOMSIM_BIN_DIR", REPO / "build" / "bin")) / "autonomsim"


def cli_run(scenario, out_dir, sets=(), seed=None) -> dict:
    """Runs `autonomsim run` into out_dir and returns its summary.json."""
    command = [str(cli_binary()), "run", str(REPO / scenario), "--out", str(out_dir)]
    for s in sets:
        command += ["--set", s]
    if seed is not None:
        command += ["--seed", str(seed)]
    done = subprocess.run(command, capture_output=True, text=True, cwd=REPO)
    assert done.returncode in (0, 1), done.stderr  # 1: an expectation failed, still a result
    return json.loads((pathlib.Path(out_dir) / "summary.json").read_text())


@pytest.fixture(autouse=True)
def _in_repository(monkeypatch):
    monkeypatch.chdir(REPO)
