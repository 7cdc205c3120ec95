"""autonomsim.load, run and run_many: the CLI's results, bit for bit."""

import sys
import threading

import numpy as np
import pytest

import autonomsim
from conftest import cli_run

STACK = "scenarios/lab_two_cars.yaml"
ORACLE = "scenarios/lab_two_cars_oracle.yaml"


def test_run_gives_the_clis_result_hash_and_summary(tmp_path):
    cli = cli_run(STACK, tmp_path / "cli", sets=["duration_s=6"], seed=7)
    result = autonomsim.run(STACK, set={"duration_s": 6}, seed=7)
    assert result.result_sha256 == cli["result_sha256"]
    assert result.summary["scenario_sha256"] == cli["scenario_sha256"]
    assert result.summary["cars"] == cli["cars"]
    assert result.passed == cli["passed"]
    assert [e["name"] for e in result.expectations] == [e["name"] for e in cli["expectations"]]


def test_the_results_tables_are_the_run_folders_files(tmp_path):
    result = autonomsim.run(ORACLE, out=tmp_path / "run", set={"duration_s": 5})
    folder = tmp_path / "run"
    lines = (folder / "trajectory.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert list(result.trajectory) == header
    rows = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    for i, column in enumerate(header):
        np.testing.assert_array_equal(result.trajectory[column], rows[:, i])
    assert len(result.events) == len((folder / "events.jsonl").read_text().splitlines())
    assert result.events[0]["type"] in {e["type"] for e in result.events}
    assert result.summary["result_sha256"] == result.result_sha256


def test_a_stack_runs_nodes_are_nodes_csvs_rows():
    result = autonomsim.run(STACK, set={"duration_s": 3})
    names = {row["node"] for row in result.nodes}
    assert "lane_planner" in names and "controller_server" in names
    frames = result.to_pandas()
    assert len(frames["trajectory"]) == len(result.trajectory["t_s"])
    assert set(frames["nodes"]["node"]) == names


def test_set_and_seed_change_the_run_as_the_command_line_does():
    base = autonomsim.run(ORACLE, set={"duration_s": 4})
    assert autonomsim.run(ORACLE, set={"duration_s": 4}).result_sha256 == base.result_sha256
    assert autonomsim.run(ORACLE, set={"duration_s": 4}, seed=43).result_sha256 != base.result_sha256
    slower = autonomsim.run(ORACLE, set={"duration_s": 4, "cars[0].oracle.speed_mps": "0.2"})
    assert slower.summary["cars"][0]["distance_m"] < base.summary["cars"][0]["distance_m"]


def test_run_many_gives_each_runs_own_result_whatever_the_jobs():
    scenarios = [autonomsim.load(ORACLE, set={"duration_s": 4}, seed=s) for s in (1, 2, 3)]
    alone = [autonomsim.run(s).result_sha256 for s in scenarios]
    for jobs in (1, 3):
        assert [r.result_sha256 for r in autonomsim.run_many(scenarios, jobs=jobs)] == alone
    assert len(set(alone)) == 3


def test_the_gil_is_released_while_a_run_runs():
    # With a switch interval of 1000 s no thread takes the GIL from another: the main thread runs
    # again only when the run's thread lets go of it. If only at its end, the run is over by then.
    scenario = autonomsim.load(ORACLE, set={"duration_s": 20})
    inside, over = threading.Event(), threading.Event()

    def work():
        inside.set()
        autonomsim.run(scenario)
        over.set()

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1000.0)
    try:
        worker = threading.Thread(target=work)
        worker.start()
        inside.wait()
        ran_during_the_run = not over.is_set()
        worker.join()
    finally:
        sys.setswitchinterval(interval)
    assert ran_during_the_run


def test_a_scenario_and_set_together_are_refused():
    with pytest.raises(TypeError):
        autonomsim.run(autonomsim.load(ORACLE), set={"duration_s": 2})
