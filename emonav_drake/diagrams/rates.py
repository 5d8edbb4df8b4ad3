"""Measured rates and wall-time shares of the systems in a diagram.

The navigation diagram mixes rates — 2.5 Hz planner, 10 Hz crowd, 200 Hz footstep
planner, 1 kHz controller and plant — and a user wants to see that the simulation runs
them as declared and where the wall time goes. Two measurements, neither of which needs
any change to the systems:

* `profile_run` runs a simulation under `cProfile`. Every Python callback a system
  declared (an update event handler, an output calculation) is a method of the system's
  class, so the profile's call counts give, per system, the events per simulated second
  (handlers that take a `state` argument) and the output evaluations per simulated
  second (handlers that take an `output` argument); their cumulative times give its
  wall time, including the Drake queries it makes (e.g. the controller's mass matrix).
  C++ systems (the `MultibodyPlant`'s discrete step with its contact solver, the scene
  graph, the simulator's own event dispatch) are what remains of the wall time: reported
  under the plant's name as "<plant> + framework" (or "framework" in a diagram without a
  MultibodyPlant); the plant's rate is the simulator's count of steps (the plant has the
  shortest period; every other one is a multiple of it).
  cProfile adds a fixed cost to every Python call, so the Python systems' shares are
  somewhat inflated (by ~10–20 % on the Digit controller); read them as a ranking.
* `record_event_times` records the simulated time of every event handler call over a
  short run (a Python profile hook: slow, for a timeline figure of a few seconds).

(pydrake does not expose a system's declared periodic events, so the rates are
measured, and the configured ones — `walking.*_period`, `crowd.dt`, `robot.step_time` —
are what they are compared with.)
"""

from __future__ import annotations

import cProfile
import dataclasses as dc
import inspect
import pstats
import sys
import time
from collections.abc import Callable

from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, LeafSystem, System

FRAMEWORK = "framework"

_Key = tuple[str, int, str]  # cProfile's (file, first line, function name)


@dc.dataclass
class Callback:
    """One Python callback of a system."""

    system: str
    name: str
    kind: str  # "event" (update handler) or "output" (calc) or "helper"


def leaf_systems(diagram: Diagram, prefix: str = "") -> list[tuple[str, System]]:
    """Every leaf system of `diagram` (recursing into sub-diagrams) with its path name
    relative to the root, e.g. "digit/controller"."""
    out = []
    for sys_ in diagram.GetSystems():
        name = f"{prefix}{sys_.get_name()}"
        if isinstance(sys_, Diagram):
            out.extend(leaf_systems(sys_, name + "/"))
        else:
            out.append((name, sys_))
    return out


def _callback_kind(fn) -> str:
    try:
        params = list(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        return "helper"
    if "state" in params and "context" in params:
        return "event"
    if "output" in params and "context" in params:
        return "output"
    if "value" in params and "context" in params:
        return "cache"  # a cache entry's calculation (e.g. one computation for two ports)
    return "helper"


def _system_methods(systems: list[tuple[str, System]]):
    """(system name, attribute, code object, function) of every method that the Python
    classes of `systems` define (Drake's own classes excluded)."""
    for name, sys_ in systems:
        for klass in type(sys_).__mro__:
            if klass in (LeafSystem, object) or klass.__module__.startswith("pydrake"):
                continue
            for attr, fn in vars(klass).items():
                code = getattr(fn, "__code__", None)
                if code is not None:
                    yield name, attr, code, fn


def python_callbacks(systems: list[tuple[str, System]]) -> dict[_Key, Callback]:
    """The methods of every Python-defined leaf system, keyed like cProfile's stats."""
    table: dict[_Key, Callback] = {}
    for name, attr, code, fn in _system_methods(systems):
        key = (code.co_filename, code.co_firstlineno, code.co_name)
        table.setdefault(key, Callback(name, attr, _callback_kind(fn)))
    return table


@dc.dataclass
class RateReport:
    """What `profile_run` measured.

    Attributes:
        sim_seconds, wall_seconds: simulated and wall time of the run [s].
        events_per_second: per system, event handler calls per simulated second.
        outputs_per_second: per system, output calculations per simulated second (of a
            system whose outputs read a cache entry: that entry's calculations).
        wall_seconds_by_system: per system [s]; the C++ remainder under
            "<plant> + framework" (or "framework").
    """

    sim_seconds: float
    wall_seconds: float
    events_per_second: dict[str, float]
    outputs_per_second: dict[str, float]
    wall_seconds_by_system: dict[str, float]

    @property
    def wall_time_share(self) -> dict[str, float]:
        total = sum(self.wall_seconds_by_system.values())
        return {k: v / total for k, v in self.wall_seconds_by_system.items()} if total else {}

    def rates(self) -> dict[str, float]:
        """Per system: events per simulated second, or output calculations per simulated
        second for a system without events (e.g. the 1 kHz controller, computed in its
        output port when the plant steps)."""
        names = set(self.events_per_second) | set(self.outputs_per_second)
        return {
            n: self.events_per_second.get(n) or self.outputs_per_second.get(n, 0.0)
            for n in sorted(names)
        }

    def to_json(self) -> dict:
        r3 = {k: round(v, 3) for k, v in self.rates().items()}
        return {
            "rates": r3,
            "events_per_second": {k: round(v, 3) for k, v in self.events_per_second.items()},
            "outputs_per_second": {k: round(v, 3) for k, v in self.outputs_per_second.items()},
            "wall_time_share": {k: round(v, 4) for k, v in self.wall_time_share.items()},
            "profiled_wall_seconds": round(self.wall_seconds, 3),
        }


def profile_run(simulator: Simulator, diagram: Diagram, run: Callable[[], None]) -> RateReport:
    """Call `run()` (which advances `simulator`) under cProfile; measure per system.

    Args:
        simulator: the simulator `run` advances (for its time and update counters).
        diagram: its root diagram.
        run: the simulation to measure, e.g. ``lambda: sim.AdvanceTo(10.0)``.
    """
    systems = leaf_systems(diagram)
    table = python_callbacks(systems)
    t_sim0 = simulator.get_context().get_time()
    steps0 = simulator.get_num_steps_taken()
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    try:
        run()
    finally:
        prof.disable()
    wall = time.perf_counter() - t0
    sim_s = simulator.get_context().get_time() - t_sim0
    stats = pstats.Stats(prof).stats  # key -> (cc, nc, tt, ct, callers)
    events: dict[str, float] = {}
    outputs: dict[str, float] = {}
    seconds: dict[str, float] = {}
    caches: dict[str, float] = {}
    for key, (_, nc, _, ct, callers) in stats.items():
        cb = table.get(key)
        if cb is None:
            continue
        if cb.kind == "cache":  # computed once however many ports read it
            caches[cb.system] = caches.get(cb.system, 0.0) + nc
            # its time is inside the port or event of the same system that asked for it
            # (through Drake's `CacheEntry.Eval`, so cProfile does not see it as internal)
            continue
        # An entry point is called by Drake, not by another method of the same system.
        internal = any(table.get(c) is not None and table[c].system == cb.system for c in callers)
        if internal:
            continue
        seconds[cb.system] = seconds.get(cb.system, 0.0) + ct
        if cb.kind == "event":
            events[cb.system] = events.get(cb.system, 0.0) + nc
        elif cb.kind == "output":
            outputs[cb.system] = outputs.get(cb.system, 0.0) + nc
    total_profiled = sum(tt for (_, _, tt, _, _) in stats.values())
    per = 1.0 / sim_s if sim_s > 0 else 0.0
    plant_name = next(
        (n for n, s in systems if type(s).__name__.startswith("MultibodyPlant")), None
    )
    rest = FRAMEWORK if plant_name is None else f"{plant_name} + {FRAMEWORK}"
    seconds[rest] = max(total_profiled - sum(seconds.values()), 0.0)
    if plant_name is not None:
        # The plant has the shortest period (every other rate is a multiple of its time
        # step), so the simulator takes one step per plant update.
        events[plant_name] = float(simulator.get_num_steps_taken() - steps0)
    return RateReport(
        sim_seconds=sim_s,
        wall_seconds=wall,
        events_per_second={k: v * per for k, v in sorted(events.items())},
        outputs_per_second={k: v * per for k, v in sorted((outputs | caches).items())},
        wall_seconds_by_system=dict(sorted(seconds.items(), key=lambda kv: -kv[1])),
    )


def record_event_times(
    simulator: Simulator, diagram: Diagram, run: Callable[[], None]
) -> dict[str, list[float]]:
    """Simulated times [s] of every event handler call per system during `run()`.

    Also the simulator's steps, under the plant's name: the context time after each
    step, recorded by a simulator monitor that then calls the one already set. Uses a
    Python profile hook: keep the run to a few seconds.
    """
    systems = leaf_systems(diagram)
    codes = {
        code: name
        for name, _, code, fn in _system_methods(systems)
        if _callback_kind(fn) == "event"
    }
    times: dict[str, list[float]] = {n: [] for n in set(codes.values())}
    plant_name = next(
        (n for n, s in systems if type(s).__name__.startswith("MultibodyPlant")), "plant"
    )
    steps: list[float] = []
    previous = simulator.get_monitor()

    def monitor(root_context):
        steps.append(root_context.get_time())
        return previous(root_context) if previous is not None else None

    def hook(frame, event, arg):
        if event == "call":
            name = codes.get(frame.f_code)
            if name is not None:
                ctx = frame.f_locals.get("context")
                if ctx is not None:
                    times[name].append(ctx.get_time())

    simulator.set_monitor(monitor)
    old = sys.getprofile()
    sys.setprofile(hook)
    try:
        run()
    finally:
        sys.setprofile(old)
        if previous is not None:
            simulator.set_monitor(previous)
        else:
            simulator.clear_monitor()
    out = {k: v for k, v in times.items() if v}
    out[plant_name] = steps
    return out


class RateMeasurement:
    """Asks an episode (`EpisodeRequest.rates`, e.g. `run_digit_episode(..., rates=m)`) to
    profile its simulation; the `RateReport` is in `report` afterwards."""

    def __init__(self) -> None:
        self.report: RateReport | None = None

    def run(self, simulator: Simulator, diagram: Diagram, fn: Callable[[], object]) -> object:
        """Call `fn()` under `profile_run`, keep the report, return what `fn` returned."""
        result: list[object] = []
        self.report = profile_run(simulator, diagram, lambda: result.append(fn()))
        return result[0]
