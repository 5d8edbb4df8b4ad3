"""One navigation episode, planner instant by planner instant: the trace either plant gives.

`EpisodeTrace` is what `Plant.simulate` returns beside the record when asked
(`EpisodeRequest.trace`), for the LIP (`diagrams/navigation.py`) and the full-order Digit
(`diagrams/navigation_digit.py`) alike: one row per planner instant t_k = kT, k = 0 … K
(K = the record's `steps`), read before the updates at t_k — what the planner sees —
the last row being the episode's end (after a fall, the instant the fall was seen; when
the simulator gave up on a robot in a heap, the last instant it reached).

Its JSONL form (`rows` / `from_rows`) is the one of the calibration trace files
(`learning/calibration.py`): one dict per row, {"k", "t", "robot", "held",
"pedestrians", "emotions"} (the reward is not written there). `trace_columns` reads the
numeric columns of either form (`robot.tracking.trace_tracking`,
`robot.step_response.transitions_from_trace`).
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Mapping, Sequence

import numpy as np

# the keys of a row dict, in the order the calibration files have them
ROW_KEYS = ("k", "t", "robot", "held", "pedestrians", "emotions")
# the width of a numeric column's rows (`trace_columns`); None: a scalar per row
WIDTHS: dict[str, int | None] = {"k": None, "t": None, "robot": 4, "held": 2}


@dc.dataclass
class EpisodeTrace:
    """One episode at every planner instant t_k (module docstring); entry i of every list
    is row i, the instant k = `k[i]` (k = i from a fresh context).

    World frame W: x towards the goal, y left; metres, radians, seconds.

    Attributes:
        k: the step index k of each row.
        t: t_k [s] (= kT).
        robot: (4,) per row: x [m], y [m], θ [rad], v [m/s] — the LIP's state, or Digit's
            CoM, torso yaw and sagittal CoM speed — at t_k.
        held: (2,) per row: the command the planner holds at t_k before its update,
            (u_v [m/s], u_Δθ [rad]) = u_{k−1}, the one of the step just ended; at k = 0
            the planner's initial command ((0, 0): the robot stood). So row k + 1's
            `held` is u_k, the command walked in step k (`commands`).
        pedestrians: (P, 2) per row: the pedestrians' centres [m].
        emotions: (P,) per row: the true emotion codes in force (0 happy, 1 neutral,
            2 negative).
        rewards: per row, the reward of the step ending at t_k (Eq. 6–9, the episode
            monitor's); NaN at k = 0 and where the monitor gives none.
        perceived: (P,) per row: the emotion code each true pedestrian has in the crowd
            the planner reads (`perceived_emotions`): −1 where the robot does not
            perceive that pedestrian (not tracked). Empty arrays when not recorded (the
            calibration files do not hold it).
    """

    k: list[int] = dc.field(default_factory=list)
    t: list[float] = dc.field(default_factory=list)
    robot: list[np.ndarray] = dc.field(default_factory=list)
    held: list[np.ndarray] = dc.field(default_factory=list)
    pedestrians: list[np.ndarray] = dc.field(default_factory=list)
    emotions: list[np.ndarray] = dc.field(default_factory=list)
    rewards: list[float] = dc.field(default_factory=list)
    perceived: list[np.ndarray] = dc.field(default_factory=list)

    def append(
        self,
        k: int,
        t: float,
        robot: np.ndarray,
        held: np.ndarray,
        pedestrians: np.ndarray,
        emotions: np.ndarray,
        reward: float = math.nan,
        perceived: np.ndarray | None = None,
    ) -> None:
        """Add the row of instant k (copies of the arrays)."""
        self.k.append(int(k))
        self.t.append(float(t))
        self.robot.append(np.array(robot, dtype=float).reshape(4))
        self.held.append(np.array(held, dtype=float).reshape(2))
        self.pedestrians.append(np.array(pedestrians, dtype=float).reshape(-1, 2))
        self.emotions.append(np.array(emotions, dtype=np.int64).reshape(-1))
        self.rewards.append(float(reward))
        self.perceived.append(
            np.zeros(0, np.int64) if perceived is None else np.array(perceived, np.int64)
        )

    def __len__(self) -> int:
        return len(self.t)

    @property
    def steps(self) -> int:
        """K, the walking steps the trace covers (rows − 1)."""
        return len(self.t) - 1

    @property
    def commands(self) -> np.ndarray:
        """(K, 2): u_k = (u_v [m/s], u_Δθ [rad]) walked in step k, k = 0 … K − 1 (rows 1 …
        K's `held`)."""
        return np.asarray(self.held[1:], dtype=float).reshape(-1, 2)

    def rows(self) -> list[dict]:
        """The rows as plain dicts, the calibration files' JSONL form: {"k", "t", "robot":
        [x, y, θ, v], "held": [u_v, u_Δθ], "pedestrians": [[x, y], ...], "emotions":
        [code, ...]} (no reward)."""
        return [
            {
                "k": k,
                "t": t,
                "robot": r.tolist(),
                "held": h.tolist(),
                "pedestrians": p.tolist(),
                "emotions": [int(e) for e in em],
            }
            for k, t, r, h, p, em in zip(
                self.k, self.t, self.robot, self.held, self.pedestrians, self.emotions, strict=True
            )
        ]

    @classmethod
    def from_rows(cls, rows: Sequence[Mapping]) -> EpisodeTrace:
        """The trace of row dicts (`rows`; a row's "reward", if any, is read too).
        KeyError / ValueError / TypeError on a malformed row."""
        trace = cls()
        for row in rows:
            trace.append(
                row["k"],
                row["t"],
                row["robot"],
                row["held"],
                row["pedestrians"],
                row["emotions"],
                row.get("reward", math.nan),
            )
        return trace


# A pedestrian of the planner's crowd is the true pedestrian i when its centre lies
# within this of i's [m] (the tracker's estimates are centimetres off; a pass-through crowd
# is exact).
PERCEIVED_MATCH = 0.5


def perceived_emotions(
    true_positions: np.ndarray, perceived_positions: np.ndarray, perceived_codes: np.ndarray
) -> np.ndarray:
    """(P,) the emotion code each true pedestrian (P, 2) [m] has in a perceived crowd
    (positions (Q, 2) [m], codes (Q,)): the code of the perceived pedestrian nearest it
    within `PERCEIVED_MATCH`, each perceived one taken once, nearest pairs first; −1 for
    a true pedestrian the crowd does not hold."""
    truth = np.asarray(true_positions, dtype=float).reshape(-1, 2)
    seen = np.asarray(perceived_positions, dtype=float).reshape(-1, 2)
    codes = np.asarray(perceived_codes, dtype=np.int64).reshape(-1)
    out = np.full(len(truth), -1, dtype=np.int64)
    if len(truth) == 0 or len(seen) == 0:
        return out
    gap = np.hypot(truth[:, None, 0] - seen[None, :, 0], truth[:, None, 1] - seen[None, :, 1])
    taken = np.zeros(len(seen), dtype=bool)
    for flat in np.argsort(gap, axis=None, kind="stable"):
        i, j = divmod(int(flat), len(seen))
        if gap[i, j] > PERCEIVED_MATCH:
            break
        if out[i] < 0 and not taken[j]:
            out[i], taken[j] = codes[j], True
    return out


def trace_columns(trace: EpisodeTrace | Sequence[Mapping], *names: str) -> list[np.ndarray]:
    """Numeric columns of a trace (`EpisodeTrace` or its row dicts, of which only these
    keys are read) as float arrays: "k", "t" (n,), "robot" (n, 4), "held" (n, 2).
    KeyError for a row without the key."""
    out = []
    for name in names:
        width = WIDTHS[name]
        if isinstance(trace, EpisodeTrace):
            values = getattr(trace, name)
        else:
            values = [e[name] for e in trace]
        a = np.array(values, dtype=float)
        out.append(a.reshape(-1) if width is None else a.reshape(-1, width))
    return out
