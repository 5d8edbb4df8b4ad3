"""The DAgger demonstrations: observation frames stored once, and labelled samples.

A sample is a window of N indices into a `FrameStore` (a 9-frame stack of 90 KB would
not fit in memory for every sample; a 10 KB frame stored once does), the vector state
(`planners.policy.vector_state`) and the expert's label: the index of its command in
the expert's command grid (`command_index`), and — when the expert is a distribution over
that grid (the LGM shield, `DaggerConfig.soft_labels`) — that distribution, the soft
label. `Demonstrations` aggregates them over the rounds of the CPU route
(`learning/dagger.py`) and of the Digit rounds (`learning/digit_dagger.py`), and converts
them to plain arrays for a run's state file and back.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np


class FrameStore:
    """Append-only observation frames; samples refer to frames by index.

    Args:
        shape: one frame's shape — (M, M) grid maps, (K,) scans, (3, M, M) DRL-VO* images;
            an int M means (M, M).
        dtype: the frames' dtype (uint8 maps, float32 scans).
    """

    def __init__(
        self, shape: int | tuple[int, ...], capacity: int = 4096, dtype: type = np.uint8
    ) -> None:
        shape = (shape, shape) if isinstance(shape, int) else tuple(shape)
        self.frames = np.zeros((capacity, *shape), dtype)
        self.count = 0

    def add(self, frame: np.ndarray) -> int:
        if self.count == len(self.frames):
            grown = np.zeros((2 * len(self.frames), *self.frames.shape[1:]), self.frames.dtype)
            grown[: self.count] = self.frames[: self.count]
            self.frames = grown
        self.frames[self.count] = frame
        self.count += 1
        return self.count - 1


@dc.dataclass
class Demonstrations:
    """Aggregated (observation, expert label) pairs."""

    store: FrameStore
    windows: list[np.ndarray] = dc.field(default_factory=list)  # (N,) frame indices
    states: list[np.ndarray] = dc.field(default_factory=list)  # (4,) vector state
    labels: list[int] = dc.field(default_factory=list)  # expert's command index
    # the expert's distribution over the grid (C,) per sample; empty for hard labels
    targets: list[np.ndarray] = dc.field(default_factory=list)

    def __len__(self) -> int:
        return len(self.labels)

    @property
    def soft(self) -> bool:
        """Whether every sample has a soft label (and there is at least one)."""
        return bool(self.targets) and len(self.targets) == len(self.labels)

    def target_array(self) -> np.ndarray | None:
        """The soft labels (n, C) float32, or None for hard labels."""
        return np.asarray(self.targets, np.float32) if self.soft else None

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (
            np.asarray(self.windows),
            np.asarray(self.states, np.float32),
            np.asarray(self.labels, np.int64),
        )

    def truncate(self, samples: int, frames: int) -> None:
        """Back to `samples` samples and `frames` stored frames (undo a partial episode)."""
        del self.windows[samples:], self.states[samples:], self.labels[samples:]
        del self.targets[samples:]
        self.store.count = frames

    def to_plain(self, num_frames: int) -> dict:
        """Frames, windows, vector states and labels as arrays (plain data)."""
        n = len(self)
        plain = {
            "frames": self.store.frames[: self.store.count].copy(),
            "windows": np.asarray(self.windows, np.int64).reshape(n, num_frames),
            "states": np.asarray(self.states, np.float32).reshape(n, 4),
            "labels": np.asarray(self.labels, np.int64).reshape(n),
        }
        if self.targets:
            plain["targets"] = np.asarray(self.targets, np.float32)
        return plain

    def load_plain(self, d: dict, num_frames: int) -> None:
        """Inverse of `to_plain` (`ValueError` if the arrays are inconsistent)."""
        frames, windows = d["frames"], d["windows"]
        states, labels = d["states"], d["labels"]
        n, size = len(labels), self.store.frames.shape[1:]
        if (
            frames.dtype != self.store.frames.dtype
            or frames.shape[1:] != size
            or windows.dtype != np.int64
            or windows.shape != (n, num_frames)
            or states.dtype != np.float32
            or states.shape != (n, 4)
            or labels.dtype != np.int64
            or labels.shape != (n,)
            or (n and not ((windows >= 0) & (windows < len(frames))).all())
            or ("targets" in d and (d["targets"].dtype != np.float32 or len(d["targets"]) != n))
        ):
            raise ValueError("the saved demonstrations are inconsistent or of another size")
        self.store.frames = frames.copy() if len(frames) else self.store.frames
        self.store.count = len(frames)
        self.windows = list(windows)
        self.states = list(states)
        self.labels = labels.tolist()
        self.targets = list(d["targets"]) if "targets" in d else []


def command_index(commands: np.ndarray, command: np.ndarray) -> int:
    """Index of the grid command nearest to `command`."""
    return int(np.argmin(np.abs(commands - command).sum(axis=1)))
