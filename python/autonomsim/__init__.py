"""autonomsim from Python: run, step, inspect and sweep scenarios (docs/python.md).

The same simulator as the ``autonomsim`` command, with the same results bit for bit: a scenario
and seed give the same ``result_sha256`` here as on the command line, however a run is taken
(``run``, ``run_many`` on threads, or a ``Simulation`` advanced in pieces).

    >>> import autonomsim
    >>> result = autonomsim.run("scenarios/lab_two_cars.yaml", set={"duration_s": 20})
    >>> result.passed, result.summary["cars"][0]["max_lateral_error_m"]

Times are simulated seconds (``_s``), lengths metres (``_m``), speeds m/s (``_mps``), angles
radians (``_rad``), as in the files a run writes (docs/outputs.md).
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

from . import _core

__version__ = _core.__version__

__all__ = [
    "ScenarioError",
    "Scenario",
    "Result",
    "Simulation",
    "CarState",
    "BoardState",
    "load",
    "run",
    "run_many",
    "sweep",
]

# ---- errors -----------------------------------------------------------------------------------

ScenarioError = _core.ScenarioError
ScenarioError.__doc__ = """Unusable scenario input: a bad file, key, value or --set override.

``str(error)`` is the command line's message, "file:line:col: key.path: message". Its parts:
``.file`` (the file, or None), ``.line`` (1-based, or None where the input has no line, e.g. an
override), ``.key`` (the key path such as ``cars[0].laps``, or None) and ``.message`` (the whole
message). A ValueError.
"""

# "file:line:col: key.path: message" (sim/core/config.h); "--set key.path: message" for an
# override; "file: message" for a file that cannot be read
_LOCATED = re.compile(r"^(?P<file>[^:\n]+?):(?P<line>\d+):(?P<col>\d+): (?P<rest>.*)$", re.S)
_KEYED = re.compile(r"^(?P<key>[A-Za-z_][\w.\[\]]*): ")
_FILE_SUFFIXES = (".yaml", ".yml", ".json", ".csv")


def _error_parts(message: str) -> tuple:
    file = line = None
    rest = message
    if message.startswith("--set "):
        rest = message[len("--set "):]
    else:
        located = _LOCATED.match(message)
        head, separator, tail = message.partition(": ")
        if located:
            file, line, rest = located["file"], int(located["line"]), located["rest"]
        elif separator and ("/" in head or head.endswith(_FILE_SUFFIXES)):
            file, rest = head, tail
    keyed = _KEYED.match(rest)
    key = keyed["key"] if keyed and not keyed["key"].endswith(_FILE_SUFFIXES) else None
    return file, line, key


ScenarioError.message = property(lambda self: str(self), doc="The whole message, as the CLI's.")
ScenarioError.file = property(lambda self: _error_parts(str(self))[0], doc="The file, or None.")
ScenarioError.line = property(lambda self: _error_parts(str(self))[1], doc="1-based line, or None.")
ScenarioError.key = property(lambda self: _error_parts(str(self))[2], doc="Key path, or None.")

# ---- scenarios --------------------------------------------------------------------------------

PathLike = Union[str, "os.PathLike[str]"]


def _overrides(values: Optional[Mapping[str, Any]]) -> list:
    """``set`` as --set arguments: a str as the command line would take it, else JSON (YAML)."""
    if not values:
        return []
    if not isinstance(values, Mapping):
        raise TypeError("set must be a dict of --set keys to values, e.g. {'v2i.loss': 0.2}")
    out = []
    for key, value in values.items():
        text = value if isinstance(value, str) else json.dumps(value)
        out.append(f"{key}={text}")
    return out


class Scenario:
    """A scenario loaded, overridden and checked, ready to run (``load`` makes one).

    Attributes: ``name``, ``file``, ``seed``, ``duration_s`` (s), ``sha256`` (of the resolved
    scenario, summary.json's ``scenario_sha256``), ``warnings`` (list of str) and ``resolved``
    (dict: the scenario and track with every default, as the run sees them).
    """

    def __init__(self, core: "_core.Scenario"):
        self._core = core

    name = property(lambda self: self._core.name)
    file = property(lambda self: self._core.file)
    seed = property(lambda self: self._core.seed)
    duration_s = property(lambda self: self._core.duration_s)
    sha256 = property(lambda self: self._core.sha256)
    warnings = property(lambda self: list(self._core.warnings))

    @property
    def resolved(self) -> dict:
        return json.loads(self._core.resolved_json)

    def __repr__(self) -> str:
        return f"<autonomsim.Scenario {self.name!r} from {self.file!r}, seed {self.seed}>"


def load(path: PathLike, set: Optional[Mapping[str, Any]] = None,
         seed: Optional[int] = None) -> Scenario:
    """Loads a scenario file, as ``autonomsim run FILE --set K=V --seed N`` does.

    ``set``: a dict of ``--set`` keys to values, e.g. ``{"v2i.loss": 0.2,
    "cars[0].platform.mapping.lane_detection.target": "sw"}``; a str value is taken as the
    command line takes it (parsed as YAML), any other value as its JSON. ``seed``: replaces the
    scenario's seed. Raises ScenarioError (with ``.file``, ``.line``, ``.key``) for bad input.
    """
    return Scenario(_core.load(os.fspath(path), _overrides(set), seed))


def _as_scenario(scenario: Union[Scenario, PathLike], set, seed) -> Scenario:
    if isinstance(scenario, Scenario):
        if set or seed is not None:
            raise TypeError("set and seed apply when loading: give a path, or load() with them")
        return scenario
    return load(scenario, set=set, seed=seed)


# ---- results ----------------------------------------------------------------------------------


def _number(text: str):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


class Result:
    """A finished run: what its folder's files hold (docs/outputs.md), in Python.

    - ``passed``: every expectation held (the CLI's exit 0).
    - ``expectations``: list of dicts (name, passed, detail, at_s, car), as summary.json's.
    - ``summary``: dict, summary.json.
    - ``result_sha256``: the hash of trajectory.csv, events.jsonl and nodes.csv; equal to the
      CLI's for the same scenario and seed.
    - ``trajectory``: dict of numpy arrays, one per column of trajectory.csv (``t_s``, ``car``,
      ``x_m``, ``y_m``, ``yaw_rad``, ``speed_mps``, ``steering_rad``, ``throttle``,
      ``curvature_cmd_per_m``, ``lateral_error_m``, ``route_progress_m``).
    - ``events``: list of dicts, the lines of events.jsonl.
    - ``nodes``: list of dicts, the rows of nodes.csv (empty without boards).
    - ``out``: the folder it was written to, or None.
    - ``to_pandas()``: the three tables as DataFrames (needs pandas).
    """

    def __init__(self, core: "_core.Finished", out: Optional[str] = None):
        self._core = core
        self.out = out
        self._cache: dict = {}

    def _cached(self, name: str, make: Callable[[], Any]):
        if name not in self._cache:
            self._cache[name] = make()
        return self._cache[name]

    passed = property(lambda self: self._core.passed)
    result_sha256 = property(lambda self: self._core.result_sha256)

    @property
    def summary(self) -> dict:
        return self._cached("summary", lambda: json.loads(self._core.summary_json()))

    @property
    def expectations(self) -> list:
        return self.summary["expectations"]

    @property
    def trajectory(self) -> dict:
        return self._cached("trajectory", self._core.trajectory)

    @property
    def events(self) -> list:
        return self._cached("events", lambda: json.loads(self._core.events_json()))

    @property
    def nodes(self) -> list:
        def rows():
            reader = csv.DictReader(io.StringIO(self._core.nodes_csv()))
            return [{k: _number(v) for k, v in row.items()} for row in reader]

        return self._cached("nodes", rows)

    def to_pandas(self) -> dict:
        """``{"trajectory": DataFrame, "events": DataFrame, "nodes": DataFrame}`` (needs pandas)."""
        import pandas as pd

        return {
            "trajectory": pd.DataFrame(self.trajectory),
            "events": pd.DataFrame(self.events),
            "nodes": pd.DataFrame(self.nodes),
        }

    def write(self, out: PathLike, force: bool = False) -> None:
        """Writes the run's folder, as ``autonomsim run --out OUT`` (``--force``) does."""
        self._core.write(os.fspath(out), force)
        self.out = os.fspath(out)

    def __repr__(self) -> str:
        verdict = "passed" if self.passed else "FAILED"
        return f"<autonomsim.Result {verdict}, result_sha256 {self.result_sha256[:16]}…>"


def _finished(core: "_core.Finished", out: Optional[PathLike], force: bool) -> Result:
    result = Result(core)
    if out is not None:
        result.write(out, force)
    return result


def run(scenario_or_path: Union[Scenario, PathLike], out: Optional[PathLike] = None,
        set: Optional[Mapping[str, Any]] = None, seed: Optional[int] = None,
        force: bool = False) -> Result:
    """Runs a scenario to its end and returns its Result; ``autonomsim run`` in Python.

    ``scenario_or_path``: a Scenario (``load``) or a scenario file; ``set`` and ``seed`` as for
    ``load`` (with a path only). ``out``: also write the run's folder there (``run --out``; an
    existing folder only with ``force``). The GIL is released while the simulation runs, so runs
    on several threads go on in parallel (``run_many``). The result's ``result_sha256`` equals
    the CLI's for the same scenario and seed.
    """
    scenario = _as_scenario(scenario_or_path, set, seed)
    return _finished(_core.run(scenario._core), out, force)


def run_many(scenarios: Iterable[Union[Scenario, PathLike]],
             jobs: Optional[int] = None) -> list:
    """Runs several scenarios on ``jobs`` threads (None: one per CPU); their Results in order.

    Each run is independent of the others and of ``jobs``: the same results as one ``run`` each.
    """
    items = [_as_scenario(s, None, None) for s in scenarios]
    workers = max(1, jobs if jobs is not None else (os.cpu_count() or 1))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(run, items))


# ---- stepping ---------------------------------------------------------------------------------


class CarState:
    """One car at ``Simulation.time_s`` (ground truth, unless named an estimate).

    ``id``; ``pose`` = (x_m, y_m, yaw_rad) in the map frame, with ``x_m``, ``y_m``, ``yaw_rad``;
    ``speed_mps``; ``steering_rad``; ``lateral_error_m`` (from its route's lane centre);
    ``route_progress_m``; ``laps``; ``estimate`` = the stack's EKF pose (x_m, y_m, yaw_rad) or
    None (no stack, or no estimate yet); ``behavior_mode`` = the stack's behaviour ("drive",
    ...), or None for an oracle-driven car.
    """

    __slots__ = ("id", "x_m", "y_m", "yaw_rad", "speed_mps", "steering_rad", "lateral_error_m",
                 "route_progress_m", "laps", "estimate", "behavior_mode")

    def __init__(self, d: dict):
        self.id = d["id"]
        pose = d["pose"]
        self.x_m, self.y_m, self.yaw_rad = pose["x_m"], pose["y_m"], pose["yaw_rad"]
        for key in ("speed_mps", "steering_rad", "lateral_error_m", "route_progress_m", "laps",
                    "behavior_mode"):
            setattr(self, key, d[key])
        e = d["estimate"]
        self.estimate = None if e is None else (e["x_m"], e["y_m"], e["yaw_rad"])

    @property
    def pose(self) -> tuple:
        return (self.x_m, self.y_m, self.yaw_rad)

    def __repr__(self) -> str:
        return (f"<CarState car {self.id} at ({self.x_m:.3f}, {self.y_m:.3f}) m, "
                f"{self.speed_mps:.3f} m/s, lateral error {self.lateral_error_m:.3f} m>")


class BoardState:
    """One car's compute board at ``Simulation.time_s``.

    ``car``, ``name``; ``busy_cores`` (cores busy now); ``cpu_percent`` (mean load since 0 s,
    100 = one core); ``nodes`` (list of dicts, each node's metrics so far: jobs, rate_hz,
    turnaround, cpu_percent, drops, ...); ``report`` (the whole report, as summary.json's
    ``platform`` entry).
    """

    def __init__(self, d: dict):
        self.car = d["car"]
        self.name = d["name"]
        self.busy_cores = d["busy_cores"]
        self.report = json.loads(d["report_json"])
        self.cpu_percent = self.report.get("cpu_percent")
        self.nodes = self.report.get("nodes", [])

    def __repr__(self) -> str:
        return f"<BoardState {self.name}: {self.busy_cores:.2f} cores busy>"


class Simulation:
    """One run taken in pieces, to look at it between them (docs/python.md#stepping).

        sim = autonomsim.Simulation(autonomsim.load("scenarios/lab_two_cars.yaml"))
        sim.advance_to(5.0)
        print(sim.cars[0].speed_mps)
        sim.run_until(lambda s: s.cars[0].laps >= 1)
        result = sim.finish()

    ``advance_to(t)`` runs every event before ``t`` (those at ``t`` come with the next piece), so
    a fault injected at ``time_s`` strikes at that instant among its events, as the scenario's own
    would. Advancing in any number of pieces, then ``finish``, gives the same ``result_sha256``
    as one ``run``. Several simulations live in one process; one simulation may be shared by
    threads (each call waits for the one in progress).
    """

    def __init__(self, scenario: Union[Scenario, PathLike],
                 set: Optional[Mapping[str, Any]] = None, seed: Optional[int] = None):
        self.scenario = _as_scenario(scenario, set, seed)
        self._core = _core.Stepper(self.scenario._core)
        self._lock = threading.Lock()

    @property
    def time_s(self) -> float:
        """The simulated time advanced to (s)."""
        with self._lock:
            return self._core.time_s

    @property
    def end_s(self) -> float:
        """The scenario's duration (s): where ``finish`` ends the run."""
        return self._core.end_s

    def advance_to(self, t_s: float) -> None:
        """Runs the simulation to ``t_s`` (s; from ``time_s`` to ``end_s``); the GIL is released."""
        with self._lock:
            self._core.advance_to(float(t_s))

    def run_until(self, predicate: Callable[["Simulation"], bool], check_every_s: float = 0.05,
                  max_s: Optional[float] = None) -> bool:
        """Advances in steps of ``check_every_s`` (s) until ``predicate(sim)`` holds.

        Checks at ``time_s`` first, then after each step, so it stops at the first checked instant
        at which the predicate holds: no later than ``check_every_s`` after the first instant it
        held. ``max_s``: advance at most that long (s); the run's end bounds it too. Returns
        whether the predicate holds (False: the limit came first).
        """
        if check_every_s <= 0:
            raise ValueError(f"check_every_s must be > 0 s, not {check_every_s}")
        start = self.time_s
        limit = self.end_s if max_s is None else min(self.end_s, start + max_s)
        step = 0
        while True:
            if predicate(self):
                return True
            if self.time_s >= limit:
                return False
            step += 1
            self.advance_to(min(limit, start + step * check_every_s))

    @property
    def cars(self) -> list:
        """Each car's CarState now, in the scenario's order."""
        with self._lock:
            return [CarState(c) for c in self._core.cars()]

    @property
    def server(self) -> dict:
        """The traffic-light server now: ``{intersection id: {"holder": car or None, "queue":
        [cars]}}`` (the queue is empty with v2i.link: mqtt, where the server is another process)."""
        with self._lock:
            areas = self._core.server()
        return {a["intersection"]: {"holder": a["holder"], "queue": a["queue"]} for a in areas}

    @property
    def boards(self) -> list:
        """The BoardState of each car that has a board, its metrics so far."""
        with self._lock:
            return [BoardState(b) for b in self._core.boards()]

    def events_since(self, t_s: float = 0.0) -> list:
        """The events (dicts, as events.jsonl's lines) at or after ``t_s`` (s) so far."""
        with self._lock:
            text = self._core.events_since_json(float(t_s))
        return json.loads(text)

    def inject(self, fault: Mapping[str, Any]) -> None:
        """Strikes a fault now: a ``faults:`` entry (docs/faults.md) with at_s = ``time_s``.

        E.g. ``sim.inject({"car_stall": {"car": 0, "for_s": 2.0}})``. Equal to the same entry
        written in the scenario with ``at_s`` at this instant. ScenarioError for a bad entry.
        """
        with self._lock:
            self._core.inject(json.dumps(fault))

    def finish(self, out: Optional[PathLike] = None, force: bool = False) -> Result:
        """Runs the rest to the end and returns the Result (``out``: also write its folder)."""
        with self._lock:
            core = self._core.finish()
        return _finished(core, out, force)

    def __repr__(self) -> str:
        return f"<autonomsim.Simulation {self.scenario.name!r} at {self.time_s} s of {self.end_s} s>"


# ---- sweeps -----------------------------------------------------------------------------------


def _vary_specs(vary) -> list:
    """``vary`` as --vary arguments: {key: [values]} or {key: "start:stop:count"}, or strings."""
    if vary is None:
        return []
    if isinstance(vary, str):
        return [vary]
    if isinstance(vary, Mapping):
        specs = []
        for key, values in vary.items():
            if isinstance(values, str):
                specs.append(f"{key}={values}")
            else:
                texts = [v if isinstance(v, str) else json.dumps(v) for v in values]
                specs.append(f"{key}={','.join(texts)}")
        return specs
    return list(vary)


def _read_table(path: str):
    try:
        import pandas as pd
    except ImportError:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
        names = rows[0].keys() if rows else []
        return {n: [_number(r[n]) if r[n] != "" else None for r in rows] for n in names}
    return pd.read_csv(path)


def sweep(study_or_scenario: PathLike, vary=None, set: Optional[Mapping[str, Any]] = None,
          repeat: Optional[int] = None, jobs: Optional[int] = None,
          out: Optional[PathLike] = None, force: bool = False, plots: bool = False):
    """Runs a sweep, as ``autonomsim sweep`` does, and returns its results table.

    ``study_or_scenario``: a study file (scenarios/studies/) or a scenario file. ``vary``:
    ``{key: [values]}`` (each value as in ``set``) or ``{key: "start:stop:count"}``, or a list
    of ``--vary`` strings ("key=a,b,c"); added to a study's own. ``set``: as for ``load``, applied
    to every run. ``repeat``: seeds per grid point (None: a study's own, 1 for a scenario). ``jobs``: threads (None: one per CPU).
    ``out``: the sweep's folder (docs/sweeps.md); a sweep run again into it is resumed (finished
    runs are not redone), as the CLI's; None: a new temporary folder. ``plots``: draw plots/
    (gnuplot). Returns results.csv: a pandas DataFrame when pandas is installed, else a dict of
    columns (lists). ScenarioError for unusable input.
    """
    if out is None:
        out = os.path.join(tempfile.mkdtemp(prefix="autonomsim_sweep_"), "sweep")
    workers = max(1, jobs if jobs is not None else (os.cpu_count() or 1))
    done = _core.sweep(os.fspath(study_or_scenario), _overrides(set), _vary_specs(vary), repeat,
                       workers, os.fspath(out), force, plots)
    if done["failures"]:
        raise RuntimeError("sweep: runs failed: " + "; ".join(done["failures"]))
    return _read_table(done["table"])
