"""docs/python.md's worked what-if runs as written."""

import os
import re
import subprocess
import sys

import autonomsim
from conftest import REPO


def example_code() -> str:
    page = (REPO / "docs" / "python.md").read_text()
    marker = page.index("python/tests/test_docs_example.py runs this block")
    block = re.search(r"```python\n(.*?)```", page[marker:], re.S)
    return block.group(1)


def test_the_bisection_example_runs_as_written(tmp_path):
    # its paths are the checkout's (scenarios/...), its figure lands in the folder it runs in
    (tmp_path / "scenarios").symlink_to(REPO / "scenarios")
    # the module this test imports, from any folder
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(autonomsim.__file__)))
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=package_parent)
    done = subprocess.run([sys.executable, "-c", example_code()], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=500)
    assert done.returncode == 0, done.stderr
    low, high = map(float, re.search(r"between ([\d.]+)x and ([\d.]+)x", done.stdout).groups())
    assert 1.0 < low < high < 32.0 and high / low <= 1.05
    assert (tmp_path / "lateral_error_vs_scale.png").stat().st_size > 10_000
    # what it printed holds: below 0.20 m at the low end, at or above it at the high end
    def max_error_m(scale):
        r = autonomsim.run("scenarios/lab_two_cars.yaml", set={
            "duration_s": 60, "cars[0].platform.cost_scale": {"lane_planner": scale}})
        return r.summary["cars"][0]["max_lateral_error_m"]

    assert max_error_m(low) < 0.20 <= max_error_m(high)
