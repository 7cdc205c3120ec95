"""autonomsim.Simulation: a run in pieces is the run in one piece; what it shows between them."""

import threading

import pytest

import autonomsim

STACK = "scenarios/lab_two_cars.yaml"
ORACLE = "scenarios/lab_two_cars_oracle.yaml"


def test_advancing_in_pieces_gives_one_runs_hash():
    scenario = autonomsim.load(STACK, set={"duration_s": 5})
    whole = autonomsim.run(scenario)
    sim = autonomsim.Simulation(scenario)
    for t_s in (0.0, 0.001, 0.5, 0.5, 1.2345, 2.0, 4.999999999):
        sim.advance_to(t_s)
        assert sim.time_s == pytest.approx(t_s, abs=1e-9)
        sim.cars, sim.server, sim.boards  # looking changes nothing
    result = sim.finish()
    assert result.result_sha256 == whole.result_sha256
    assert result.summary["cars"] == whole.summary["cars"]


def test_the_state_between_pieces_is_the_trajectorys_sample_there():
    scenario = autonomsim.load(ORACLE, set={"duration_s": 4})
    trajectory = autonomsim.run(scenario).trajectory
    sim = autonomsim.Simulation(scenario)
    # samples are taken at t (every output.trajectory_period); advance_to(t + a little) has run them
    sim.advance_to(2.0 + 1e-6)
    for car in sim.cars:
        row = (trajectory["t_s"] == 2.0) & (trajectory["car"] == car.id)
        assert row.sum() == 1
        assert car.x_m == pytest.approx(float(trajectory["x_m"][row][0]), abs=0.01)
        assert car.speed_mps == pytest.approx(float(trajectory["speed_mps"][row][0]), abs=0.05)
        assert car.behavior_mode is None and car.estimate is None  # oracle cars: no stack


def test_stack_cars_show_their_estimate_mode_and_boards():
    sim = autonomsim.Simulation(STACK, set={"duration_s": 4})
    sim.advance_to(3.0)
    for car in sim.cars:
        assert car.behavior_mode is not None
        x, y, _ = car.estimate
        assert abs(x - car.x_m) < 0.3 and abs(y - car.y_m) < 0.3
    boards = sim.boards
    assert [b.car for b in boards] == [0, 1]
    lane = next(n for n in boards[0].nodes if n["name"] == "lane_planner")
    assert lane["jobs"] > 0
    early = next(n for n in autonomsim.Simulation(STACK, set={"duration_s": 4}).boards[0].nodes
                 if n["name"] == "lane_planner")
    assert early["jobs"] == 0


def test_run_until_stops_at_the_first_check_where_the_predicate_holds():
    scenario = autonomsim.load(ORACLE, set={"duration_s": 30})
    trajectory = autonomsim.run(scenario).trajectory
    car0 = trajectory["car"] == 0
    # the first sampled instant at which car 0 has gone 1 m along its route
    first = float(trajectory["t_s"][car0][trajectory["route_progress_m"][car0] >= 1.0][0])
    sim = autonomsim.Simulation(scenario)
    check = 0.05
    assert sim.run_until(lambda s: s.cars[0].route_progress_m >= 1.0, check_every_s=check)
    # it held at time_s, not one check before
    assert sim.cars[0].route_progress_m >= 1.0
    assert first - 0.1 <= sim.time_s <= first + check + 0.1
    before = autonomsim.Simulation(scenario)
    before.advance_to(sim.time_s - check)
    assert before.cars[0].route_progress_m < 1.0
    assert sim.finish().result_sha256 == autonomsim.run(scenario).result_sha256


def test_run_until_gives_up_at_max_s_or_the_end():
    sim = autonomsim.Simulation(ORACLE, set={"duration_s": 3})
    assert not sim.run_until(lambda s: False, check_every_s=0.5, max_s=1.2)
    assert sim.time_s == pytest.approx(1.2)
    assert not sim.run_until(lambda s: False, check_every_s=0.5)
    assert sim.time_s == pytest.approx(3.0)


def test_events_since_are_the_runs_events_so_far():
    scenario = autonomsim.load(ORACLE, set={"duration_s": 20})
    events = autonomsim.run(scenario).events
    sim = autonomsim.Simulation(scenario)
    sim.advance_to(10.0)
    assert sim.events_since(0.0) == [e for e in events if e["t_s"] < 10.0]
    assert sim.events_since(5.0) == [e for e in events if 5.0 <= e["t_s"] < 10.0]


def test_two_simulations_in_one_process_and_on_threads():
    a_scenario = autonomsim.load(ORACLE, set={"duration_s": 6}, seed=1)
    b_scenario = autonomsim.load(STACK, set={"duration_s": 3}, seed=2)
    a, b = autonomsim.Simulation(a_scenario), autonomsim.Simulation(b_scenario)
    for t in (1.0, 2.0, 3.0):  # interleaved
        a.advance_to(t)
        b.advance_to(t)
    results = {}

    def finish(name, sim):
        results[name] = sim.finish().result_sha256

    threads = [threading.Thread(target=finish, args=p) for p in (("a", a), ("b", b))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results["a"] == autonomsim.run(a_scenario).result_sha256
    assert results["b"] == autonomsim.run(b_scenario).result_sha256


def test_stepping_outside_the_run_is_refused():
    sim = autonomsim.Simulation(ORACLE, set={"duration_s": 2})
    sim.advance_to(1.0)
    with pytest.raises(RuntimeError):
        sim.advance_to(0.5)
    with pytest.raises(RuntimeError):
        sim.advance_to(2.5)
    sim.finish()
    with pytest.raises(RuntimeError):
        sim.finish()


def test_the_server_shows_the_holder_the_grant_events_name():
    scenario = autonomsim.load(ORACLE, set={"duration_s": 30})
    events = autonomsim.run(scenario).events
    grant = next(e for e in events if e["type"] == "grant")
    sim = autonomsim.Simulation(scenario)
    sim.advance_to(grant["t_s"])  # the grant is among the events at its instant: not yet
    assert sim.server[grant["intersection"]]["holder"] != grant["car"]
    sim.advance_to(grant["t_s"] + 1e-6)
    assert sim.server[grant["intersection"]]["holder"] == grant["car"]
    assert set(sim.server) == {0, 1}


def test_the_server_shows_the_car_a_denial_queued():
    # fifo: a request for a held intersection is denied and the car queued until it is granted
    scenario = autonomsim.load(ORACLE, set={"duration_s": 30})
    events = autonomsim.run(scenario).events
    denied = next(e for e in events if e["type"] == "denied")
    area = denied["intersection"]
    sim = autonomsim.Simulation(scenario)
    sim.advance_to(denied["t_s"] + 1e-6)
    assert denied["car"] in sim.server[area]["queue"]
    assert sim.server[area]["holder"] not in (None, denied["car"])
    granted = next(e for e in events if e["type"] == "grant" and e["car"] == denied["car"]
                   and e["intersection"] == area and e["t_s"] > denied["t_s"])
    sim.advance_to(granted["t_s"] + 1e-6)
    assert sim.server[area] == {"holder": denied["car"], "queue": []}


def test_finish_writes_the_folder_run_writes(tmp_path):
    scenario = autonomsim.load(ORACLE, set={"duration_s": 3})
    autonomsim.run(scenario, out=tmp_path / "whole")
    sim = autonomsim.Simulation(scenario)
    sim.advance_to(1.5)
    sim.finish(out=tmp_path / "pieces")
    for name in ("trajectory.csv", "events.jsonl"):
        assert (tmp_path / "pieces" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes()
