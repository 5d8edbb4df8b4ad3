"""How the full-order walking stack answers a navigation command, one walking step at a time.

The LIP model of the paper (Eq. 1) turns by u_Δθ at the start of step k and reaches the
speed u_v at its end. The full-order Digit does not: its footstep planner reads the held
command at its own foot switches, which fall at or just before the planner's instants, so
step k is mostly driven by the previous command u_{k−1}, and the torso's heading and the
CoM's speed follow the footholds with their own dynamics and errors. Measured on Digit
navigation episodes (`learning/digit_rollouts.py`), this module fits a per-step response
model

    y_k = φ(s_k, u_{k−1}, u_k) · C + ε_k,      ε_k ~ N(0, diag(σ²)),

where s_k = (x, y, θ, v̄) is the robot at the planner instant t_k (CoM [m], heading
[rad], world frame; v̄ the CoM's forward speed averaged over the previous step [m/s]), and
y_k holds the step's outcome in the frame of
θ_k: forward and lateral CoM displacement [m], heading change [rad] and the next speed
[m/s]. φ is a short list of physically meaningful features (`FEATURES`): the speeds
commanded for this and the previous step, the current speed, the turns, and the turn ×
speed products that move the CoM sideways. C is fitted by least squares; σ is the
residual's standard deviation on the fitting data, and `evaluate` reports the errors on
held-out data. `step` and `rollout` apply the model, so the same numbers drive the
calibrated navigation world (`navigation.lip_world.NavigationWorld(response=...)`) and the
expert that plans with it (`planners.dwa.DwaPlanner(response=...)`).

Everything here is NumPy; the model is plain data (`to_plain` / `from_plain`, JSON).
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Iterable, Sequence

import numpy as np

from emonav_drake.navigation.episode_trace import EpisodeTrace, trace_columns
from emonav_drake.robot.lip import LipState, held_plans, lip_steps, wrap_angle, wrap_angles

FEATURES = (
    "u_v[k-2]",  # commanded speed of step k − 2 [m/s]
    "u_v[k-1]",
    "u_v[k]",
    "speed",  # v̄_k [m/s]
    "u_turn[k-2]",  # commanded heading change of step k − 2 [rad]
    "u_turn[k-1]",
    "u_turn[k]",
    "one",
)
LAGS = 3  # commands u_{k−2}, u_{k−1}, u_k
OUTPUTS = ("forward", "lateral", "turn", "speed_next")
UNITS = ("m", "m", "rad", "m/s")
FORMAT = "emonav-step-response/1"


def features(speed: np.ndarray, commands: np.ndarray) -> np.ndarray:
    """φ (…, 8) for speeds v̄ (…,) and commands (…, 3, 2) = u_{k−2}, u_{k−1}, u_k."""
    speed = np.asarray(speed, float)
    u = np.asarray(commands, float)
    return np.concatenate(
        [u[..., 0], speed[..., None], u[..., 1], np.ones_like(speed)[..., None]], axis=-1
    )


def outcome(state: np.ndarray, next_state: np.ndarray) -> np.ndarray:
    """y (…, 4): forward, lateral displacement in the frame of θ_k, Δθ wrapped, v_{k+1}."""
    s, s1 = np.asarray(state, float), np.asarray(next_state, float)
    dx, dy = s1[..., 0] - s[..., 0], s1[..., 1] - s[..., 1]
    c, sn = np.cos(s[..., 2]), np.sin(s[..., 2])
    turn = wrap_angles(s1[..., 2] - s[..., 2])
    return np.stack([c * dx + sn * dy, -sn * dx + c * dy, turn, s1[..., 3]], axis=-1)


@dc.dataclass(frozen=True)
class Transitions:
    """Step transitions (x_k, u_{k−1}, u_k) → x_{k+1} of the robot at the planner instants.

    Attributes:
        states, next_states: (n, 4) [x, y, θ, v̄] at t_k and t_{k+1}.
        commands: (n, 3, 2) the commands of steps k − 2, k − 1 and k.
        episode: (n,) an episode id per transition (for held-out splits by episode).
    """

    states: np.ndarray
    next_states: np.ndarray
    commands: np.ndarray
    episode: np.ndarray

    def __len__(self) -> int:
        return len(self.states)

    def select(self, mask: np.ndarray) -> Transitions:
        return Transitions(
            self.states[mask], self.next_states[mask], self.commands[mask], self.episode[mask]
        )

    @staticmethod
    def concatenate(parts: Sequence[Transitions]) -> Transitions:
        return Transitions(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in
                             dc.fields(Transitions)))  # fmt: skip


def transitions_from_trace(
    trace: EpisodeTrace | Sequence[dict], step_time: float, episode: int = 0, skip: int = 2
) -> Transitions:
    """The transitions of one episode's trace: an `EpisodeTrace` (`navigation/episode_trace.py`)
    or its row dicts (entries {"robot", "held"} per planner instant, as in the calibration
    trace files).

    Entry k holds the robot at t_k and the command held before t_k's update, u_{k−1}, so
    u_k is entry k + 1's "held". The speed of a state is the step-averaged one, v̄_k =
    (forward CoM displacement over step k − 1) / T: the instantaneous sagittal speed of a
    walking robot swings within every step, and where the planner instant falls in that
    swing is not a state the navigation level can model. The first `skip` ≥ 1
    transitions (standing start) and the last (a fall ends an episode mid-step) are left out;
    the command before the first is zero (the robot stood).
    """
    if skip < 1:
        raise ValueError(f"skip = {skip}: must be >= 1 (v̄ needs the previous step)")
    robot, held = trace_columns(trace, "robot", "held")
    if len(robot) >= 2:
        robot[1:, 3] = outcome(robot[:-1], robot[1:])[:, 0] / step_time
    n = len(trace) - 2  # transitions k → k + 1 with u_k known: k = 0 … len − 3
    ks = np.arange(skip, max(skip, n))
    # held[j] = u_{j−1} (held[0] = u_{−1} = 0: the robot stood): u_{k−2}, u_{k−1}, u_k
    cmds = np.stack([held[ks - 1], held[ks], held[ks + 1]], axis=1).reshape(-1, LAGS, 2)
    return Transitions(robot[ks], robot[ks + 1], cmds, np.full(len(ks), episode, np.int64))


@dc.dataclass(frozen=True)
class StepResponseModel:
    """The fitted per-step response (module docstring).

    Attributes:
        coef: (len(FEATURES), len(OUTPUTS)) least-squares coefficients C.
        residual_std: (4,) σ of forward [m], lateral [m], turn [rad], next speed [m/s].
        samples: transitions it was fitted on.
        source: where the data came from (free text: planners, seeds, commit).
    """

    coef: np.ndarray
    residual_std: np.ndarray
    samples: int
    source: str = ""

    def predict(self, speed: np.ndarray, commands: np.ndarray) -> np.ndarray:
        """The expected y (…, 4) (`OUTPUTS`) for v̄ (…,) and commands (…, 3, 2)."""
        return features(speed, commands) @ self.coef

    def step(
        self,
        state: LipState,
        commands: np.ndarray,
        rng: np.random.Generator | None = None,
    ) -> LipState:
        """The robot at the next planner instant, given (u_{k−2}, u_{k−1}, u_k) (3, 2);
        with `rng`, one draw of the residual ε is added."""
        y = self.predict(np.float64(state.speed), commands)
        if rng is not None:
            y = y + rng.standard_normal(len(OUTPUTS)) * self.residual_std
        c, s = math.cos(state.heading), math.sin(state.heading)
        return LipState(
            state.x + c * y[0] - s * y[1],
            state.y + s * y[0] + c * y[1],
            wrap_angle(state.heading + y[2]),
            float(max(y[3], 0.0)),
        )

    def rollout(
        self, state: LipState, committed: np.ndarray, candidates: np.ndarray, steps: int
    ) -> np.ndarray:
        """Expected CoM positions (C, 2·steps, 2) at the middle (halfway along the step's
        displacement) and end of each of `steps` steps, for every candidate command (C, 2)
        held from this step on; `committed` (2, 2) = (u_{k−2}, u_{k−1}), already sent."""
        return self.rollout_plans(state, committed, held_plans(candidates, steps))

    def rollout_plans(
        self, state: LipState, committed: np.ndarray, plans: np.ndarray
    ) -> np.ndarray:
        """`rollout` for command plans (C, H, 2): plan c sends plans[c, h] at step h."""
        plan = np.asarray(plans, float)
        if plan.ndim != 3 or plan.shape[2] != 2:
            raise ValueError(f"plans must be (C, H, 2), got {plan.shape}")
        n, steps = plan.shape[:2]
        hist = np.broadcast_to(np.asarray(committed, float), (n, LAGS - 1, 2))
        out = np.empty((n, 2 * steps, 2))
        x, y = np.full(n, state.x), np.full(n, state.y)
        th, v = np.full(n, state.heading), np.full(n, state.speed)
        for h in range(steps):
            cmds = np.concatenate([hist, plan[:, h, None, :]], axis=1)
            yk = self.predict(v, cmds)
            c, s = np.cos(th), np.sin(th)
            dx, dy = c * yk[:, 0] - s * yk[:, 1], s * yk[:, 0] + c * yk[:, 1]
            out[:, 2 * h, 0], out[:, 2 * h, 1] = x + dx / 2, y + dy / 2
            x, y = x + dx, y + dy
            out[:, 2 * h + 1, 0], out[:, 2 * h + 1, 1] = x, y
            th, v, hist = th + yk[:, 2], np.maximum(yk[:, 3], 0.0), cmds[:, 1:]
        return out

    def to_plain(self) -> dict:
        return {
            "format": FORMAT,
            "features": list(FEATURES),
            "outputs": list(OUTPUTS),
            "coef": self.coef.tolist(),
            "residual_std": self.residual_std.tolist(),
            "samples": self.samples,
            "source": self.source,
        }

    @staticmethod
    def from_plain(d: dict) -> StepResponseModel:
        """Inverse of `to_plain`; `ValueError` naming what does not fit."""
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise ValueError(f"not a step-response model (format must be {FORMAT!r})")
        if list(d.get("features", [])) != list(FEATURES) or list(d.get("outputs", [])) != list(
            OUTPUTS
        ):
            raise ValueError("the model's features or outputs are not this version's")
        coef = np.asarray(d["coef"], float)
        std = np.asarray(d["residual_std"], float)
        if coef.shape != (len(FEATURES), len(OUTPUTS)) or std.shape != (len(OUTPUTS),):
            raise ValueError(f"coef {coef.shape} / residual_std {std.shape} have wrong shapes")
        if not (np.isfinite(coef).all() and np.isfinite(std).all() and (std >= 0).all()):
            raise ValueError("coef and residual_std must be finite (residual_std >= 0)")
        return StepResponseModel(coef, std, int(d["samples"]), str(d.get("source", "")))


def lip_errors(data: Transitions, omega: float, step_time: float, delay: int) -> np.ndarray:
    """Per-transition errors y − ŷ (n, 4) of the LIP step map (Eq. 1) driven by u_k
    (`delay` 0, the paper's model), u_{k−1} (1) or u_{k−2} (2)."""
    pred = lip_steps(data.states, data.commands[:, LAGS - 1 - delay], omega, step_time)
    return outcome(data.states, data.next_states) - outcome(data.states, pred)


def fit_step_response(
    data: Transitions, source: str = "", ridge: float = 1e-6
) -> StepResponseModel:
    """Least-squares C (with a tiny ridge for conditioning) and the residual σ."""
    if len(data) < 2 * len(FEATURES):
        raise ValueError(
            f"{len(data)} transitions are too few to fit {len(FEATURES)} features per output"
        )
    X = features(data.states[:, 3], data.commands)
    Y = outcome(data.states, data.next_states)
    A = X.T @ X + ridge * np.eye(X.shape[1])
    coef = np.linalg.solve(A, X.T @ Y)
    resid = Y - X @ coef
    return StepResponseModel(coef, resid.std(axis=0), len(data), source)


def evaluate(model: StepResponseModel, data: Transitions) -> np.ndarray:
    """Errors y − ŷ (n, 4) of `model` on `data` (`rms` summarises them)."""
    return outcome(data.states, data.next_states) - model.predict(data.states[:, 3], data.commands)


def rms(errors: np.ndarray) -> np.ndarray:
    """Root-mean-square (4,) of per-transition errors."""
    return np.sqrt(np.mean(np.square(errors), axis=0))


def split_by_episode(data: Transitions, held_out: Iterable[int]) -> tuple[Transitions, Transitions]:
    """(fit, held-out) by episode id."""
    mask = np.isin(data.episode, list(held_out))
    return data.select(~mask), data.select(mask)
