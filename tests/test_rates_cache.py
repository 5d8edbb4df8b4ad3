"""`diagrams/rates.profile_run` on a system whose two output ports read one cache entry
(as the passivity controller's torques and desired state do): the computation is counted
once, in calls and in time."""

import time

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem, ValueProducer

from emonav_drake.diagrams.rates import profile_run

BURN = 0.002  # seconds of work per computation


class TwoPortsOneCache(LeafSystem):
    def __init__(self) -> None:
        super().__init__()
        self.computed = 0
        self._cache = self.DeclareCacheEntry(
            "the shared computation",
            ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(2)), calc=self._calc),
            {self.time_ticket()},
        )
        self.DeclareVectorOutputPort("a", 1, self._a)
        self.DeclareVectorOutputPort("b", 1, self._b)

    def _calc(self, context, value) -> None:
        self.computed += 1
        end = time.perf_counter() + BURN
        while time.perf_counter() < end:
            pass
        value.set_value(np.array([context.get_time(), 1.0]))

    def _a(self, context, output) -> None:
        output.SetFromVector(self._cache.Eval(context)[:1])

    def _b(self, context, output) -> None:
        output.SetFromVector(self._cache.Eval(context)[1:])


class Reader(LeafSystem):
    """Reads both ports every 10 ms."""

    def __init__(self) -> None:
        super().__init__()
        self._a = self.DeclareVectorInputPort("a", 1)
        self._b = self.DeclareVectorInputPort("b", 1)
        self.DeclarePeriodicPublishEvent(0.01, 0.0, self._read)

    def _read(self, context) -> None:
        self._a.Eval(context)
        self._b.Eval(context)


def test_a_cache_read_by_two_ports_is_counted_once():
    b = DiagramBuilder()
    source = b.AddNamedSystem("source", TwoPortsOneCache())
    reader = b.AddNamedSystem("reader", Reader())
    b.Connect(source.GetOutputPort("a"), reader.GetInputPort("a"))
    b.Connect(source.GetOutputPort("b"), reader.GetInputPort("b"))
    diagram = b.Build()
    sim = Simulator(diagram)
    report = profile_run(sim, diagram, lambda: sim.AdvanceTo(0.5))
    assert source.computed == 51  # t = 0, 0.01, …, 0.5
    assert report.rates()["source"] == 102.0  # computations per simulated second, not 204
    burned = source.computed * BURN
    # its time once (cProfile adds a little), not twice
    assert burned <= report.wall_seconds_by_system["source"] < 1.5 * burned
