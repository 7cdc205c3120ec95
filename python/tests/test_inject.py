"""Simulation.inject: a fault struck now is the same fault written in the scenario."""

import pytest

import autonomsim

ORACLE = "scenarios/lab_two_cars_oracle.yaml"
STACK = "scenarios/lab_two_cars.yaml"


@pytest.mark.parametrize("scenario, duration_s, at_s, fault", [
    (ORACLE, 8, 2.0, {"car_stall": {"car": 0, "for_s": 1.5}}),
    (STACK, 5, 1.5, {"node_hang": {"car": 1, "node": "lane_planner", "for_s": 0.8}}),
    (STACK, 5, 2.25, {"localization_jump": {"car": 0, "dx_m": 0.1}}),
    (STACK, 5, 2.0, {"remap": {"car": 0, "node": "obstacle_detection", "target": "sw"}}),
])
def test_an_injected_fault_equals_the_same_fault_in_the_scenario(scenario, duration_s, at_s, fault):
    (kind, args), = fault.items()
    written = dict(args, at_s=at_s)
    in_file = autonomsim.run(scenario, set={"duration_s": duration_s, "faults": [{kind: written}]})
    without = autonomsim.run(scenario, set={"duration_s": duration_s, "faults": []})
    sim = autonomsim.Simulation(scenario, set={"duration_s": duration_s, "faults": []})
    sim.advance_to(at_s)
    sim.inject(fault)
    injected = sim.finish()
    assert injected.result_sha256 == in_file.result_sha256
    assert injected.result_sha256 != without.result_sha256
    begins = [e for e in injected.events if e["type"] == "fault_begin"]
    assert [e["t_s"] for e in begins] == [at_s]


def test_a_fault_for_a_car_the_run_lacks_is_a_scenario_error():
    sim = autonomsim.Simulation(ORACLE, set={"duration_s": 2})
    with pytest.raises(autonomsim.ScenarioError) as caught:
        sim.inject({"car_stall": {"car": 7}})
    assert "car 7" in str(caught.value)
    assert caught.value.key == "car_stall.car"
    with pytest.raises(autonomsim.ScenarioError) as caught:
        sim.inject({"car_stal": {"car": 0}})
    assert "did you mean 'car_stall'" in str(caught.value)
    assert (caught.value.key, caught.value.file, caught.value.line) == ("car_stal", None, None)
    with pytest.raises(autonomsim.ScenarioError) as caught:
        sim.inject({"car_stall": {"car": 0, "for_s": -1.0}})
    assert caught.value.key == "car_stall.for_s"
    with pytest.raises(autonomsim.ScenarioError):
        sim.inject({"node_crash": {"car": 0, "node": "lane_planner"}})  # an oracle car: no board
