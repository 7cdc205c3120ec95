"""ScenarioError: the CLI's message, with its file, line and key."""

import subprocess

import pytest

import autonomsim
from conftest import REPO, cli_binary


def cli_error(path, sets=()) -> str:
    command = [str(cli_binary()), "run", str(path)] + [a for s in sets for a in ("--set", s)]
    done = subprocess.run(command, capture_output=True, text=True, cwd=REPO)
    assert done.returncode == 2
    return done.stderr


def test_a_bad_value_in_a_file_names_its_file_line_and_key(tmp_path):
    text = (REPO / "scenarios/lab_two_cars_oracle.yaml").read_text()
    lines = text.splitlines()
    row = next(i for i, l in enumerate(lines) if l.startswith("duration_s:"))
    lines[row] = "duration_s: -3"
    bad = tmp_path / "bad.yaml"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(autonomsim.ScenarioError) as caught:
        autonomsim.load(bad)
    error = caught.value
    assert error.file == str(bad)
    assert error.line == row + 1
    assert error.key == "duration_s"
    assert str(error) in cli_error(bad)
    assert isinstance(error, ValueError)


def test_an_unknown_key_in_set_names_the_key():
    with pytest.raises(autonomsim.ScenarioError) as caught:
        autonomsim.run("scenarios/lab_two_cars_oracle.yaml", set={"v2i.losss": 0.1})
    assert caught.value.key == "v2i.losss"
    assert caught.value.file is None and caught.value.line is None
    assert str(caught.value) in cli_error("scenarios/lab_two_cars_oracle.yaml", ["v2i.losss=0.1"])


def test_a_missing_file_is_a_scenario_error():
    with pytest.raises(autonomsim.ScenarioError) as caught:
        autonomsim.load("scenarios/no_such_file.yaml")
    assert caught.value.file == "scenarios/no_such_file.yaml"
    assert caught.value.key is None
