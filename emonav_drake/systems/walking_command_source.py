"""`WalkingCommandSource`: navigation commands (u_v, u_Δθ) for the walking diagram, per step.

Input port:
    next_step (1): how many walking steps the footstep planner has started so far, n
        (from `AlipFootstepPlanner.next_step`).
Output port:
    command (2): (u_v [m/s], u_Δθ [rad]) of the step in progress, step n − 1 (0-based;
        step 0's before the first step), as the navigation planner holds the command of
        the step in progress: the footstep planner takes it up just after the step
        starts. A pure function of n: the same seed gives the same sequence, whatever the
        simulation's timing.

Modes: "straight" (constant speed, no turn), "turn" (turning in place: zero speed and a
constant heading change), "random" (a new uniform (u_v, u_Δθ) within the paper's bounds
every step, seeded), "stand" (zero), or an explicit per-step list ("scripted"; the last
entry repeats).
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from emonav_drake.params import RobotParams


def command_sequence(
    mode: str,
    num_steps: int,
    robot: RobotParams,
    seed: int = 0,
    speed: float | None = None,
    heading_change: float | None = None,
    script: list[tuple[float, float]] | None = None,
) -> np.ndarray:
    """Per-step commands, shape (num_steps, 2).

    Args:
        mode: "straight", "turn", "random", "stand" or "scripted".
        num_steps: how many steps to generate.
        robot: the bounds ū_v, ū_Δθ.
        seed: for "random".
        speed: u_v for "straight" [m/s] (default ū_v).
        heading_change: u_Δθ per step for "turn" [rad] (default ū_Δθ / 2).
        script: the (u_v, u_Δθ) list for "scripted".
    """
    n = max(int(num_steps), 1)
    seq = np.zeros((n, 2))
    if mode == "straight":
        seq[:, 0] = robot.max_speed if speed is None else speed
    elif mode == "turn":
        seq[:, 1] = 0.5 * robot.max_heading_change if heading_change is None else heading_change
    elif mode == "random":
        # one (u_v, u_Δθ) pair per draw: the first k steps do not depend on num_steps
        unit = np.random.default_rng(seed).uniform(0.0, 1.0, (n, 2))
        seq[:, 0] = unit[:, 0] * robot.max_speed
        seq[:, 1] = (2.0 * unit[:, 1] - 1.0) * robot.max_heading_change
    elif mode == "scripted":
        if not script:
            raise ValueError("scripted commands need a non-empty script")
        s = np.asarray(script, dtype=float).reshape(-1, 2)
        seq[: len(s)] = s[:n]
        seq[len(s) :] = s[-1]
    elif mode != "stand":
        raise ValueError(f"unknown command mode {mode!r}: straight, turn, random, stand, scripted")
    return seq


class WalkingCommandSource(LeafSystem):
    """Commands indexed by walking step (see the module docstring).

    Args:
        sequence: (N, 2) commands; past the end the last one repeats.
    """

    def __init__(self, sequence: np.ndarray) -> None:
        super().__init__()
        self._seq = np.asarray(sequence, dtype=float).reshape(-1, 2)
        self._next = self.DeclareVectorInputPort("next_step", 1)
        self.DeclareVectorOutputPort("command", 2, self._calc_command)

    @property
    def sequence(self) -> np.ndarray:
        return self._seq

    def _calc_command(self, context: Context, output: BasicVector) -> None:
        n = int(round(self._next.Eval(context)[0])) - 1  # the step in progress
        output.SetFromVector(self._seq[min(max(n, 0), len(self._seq) - 1)])
