"""Replay buffer that stores every observation frame once (uint8) and indexes N-frame windows.

A (9, 100, 100) uint8 stack is 90 KB; consecutive stacks share 8 frames, so each
transition stores only the frame indices of its observation and next observation. The
frame ring holds twice the transition capacity (plus a margin), which is more than a
transition still in the buffer can reference (one new frame per step, one per reset).
"""

from __future__ import annotations

import numpy as np
import torch


class FrameReplayBuffer:
    """Ring buffer of transitions over a ring of frames.

    Args:
        capacity: transitions kept.
        frame_shape: shape of one frame, e.g. (100, 100) (LGM) or (1800,) (LiDAR scan).
        frame_dtype: np.uint8 for grid maps, np.float32 for scans.
        num_frames: N, frames per observation window.
    """

    def __init__(
        self, capacity: int, frame_shape: tuple[int, ...], frame_dtype: type, num_frames: int
    ) -> None:
        self.capacity, self.num_frames = capacity, num_frames
        self.frames = np.zeros((2 * capacity + 2 * num_frames + 2, *frame_shape), frame_dtype)
        self.next_frame = 0
        self.obs_ids = np.zeros((capacity, num_frames), np.int64)
        self.next_ids = np.zeros((capacity, num_frames), np.int64)
        self.state = np.zeros((capacity, 4), np.float32)
        self.next_state = np.zeros((capacity, 4), np.float32)
        self.action = np.zeros((capacity, 2), np.float32)
        self.reward = np.zeros((capacity, 1), np.float32)
        self.not_done = np.zeros((capacity, 1), np.float32)
        self.size = 0
        self.pos = 0

    def add_frame(self, frame: np.ndarray) -> int:
        """Store one frame; returns its id."""
        i = self.next_frame
        self.frames[i] = frame
        self.next_frame = (i + 1) % len(self.frames)
        return i

    def add(
        self,
        obs_ids: np.ndarray,
        state: np.ndarray,
        action: np.ndarray,
        reward: float,
        next_ids: np.ndarray,
        next_state: np.ndarray,
        terminal: bool,
    ) -> None:
        """One transition; `terminal` only for true terminations (not time limits)."""
        p = self.pos
        self.obs_ids[p], self.next_ids[p] = obs_ids, next_ids
        self.state[p], self.next_state[p] = state, next_state
        self.action[p], self.reward[p, 0] = action, reward
        self.not_done[p, 0] = 0.0 if terminal else 1.0
        self.pos = (p + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def sample(
        self, batch: int, rng: np.random.Generator, device: torch.device
    ) -> dict[str, torch.Tensor]:
        idx = rng.integers(0, self.size, batch)

        def t(a: np.ndarray) -> torch.Tensor:
            return torch.from_numpy(a).to(device)

        return {
            "obs": t(self.frames[self.obs_ids[idx]]),
            "state": t(self.state[idx]),
            "action": t(self.action[idx]),
            "reward": t(self.reward[idx]),
            "next_obs": t(self.frames[self.next_ids[idx]]),
            "next_state": t(self.next_state[idx]),
            "not_done": t(self.not_done[idx]),
        }

    _ARRAYS = (
        "frames",
        "obs_ids",
        "next_ids",
        "state",
        "next_state",
        "action",
        "reward",
        "not_done",
    )

    def state_dict(self) -> dict:
        """The buffer as plain data: its NumPy arrays (not copies) and counters."""
        st = {k: getattr(self, k) for k in self._ARRAYS}
        return st | {"next_frame": self.next_frame, "size": self.size, "pos": self.pos}

    def load_state_dict(self, st: dict) -> None:
        """Restore `state_dict()`; `ValueError` if the arrays do not fit this buffer."""
        for k in self._ARRAYS:
            mine, theirs = getattr(self, k), st[k]
            if not isinstance(theirs, np.ndarray) or theirs.shape != mine.shape:
                raise ValueError(
                    f"replay {k}: saved shape {np.shape(theirs)} != {mine.shape} "
                    "(replay_size, num_frames or the observation differ from the run's)"
                )
            if theirs.dtype != mine.dtype:
                raise ValueError(f"replay {k}: saved dtype {theirs.dtype} != {mine.dtype}")
        counters = {k: int(st[k]) for k in ("next_frame", "size", "pos")}
        if not (
            0 <= counters["next_frame"] < len(self.frames)
            and 0 <= counters["pos"] < self.capacity
            and 0 <= counters["size"] <= self.capacity
        ):
            raise ValueError(f"replay counters {counters} are out of range")
        for k in self._ARRAYS:
            setattr(self, k, st[k])
        for k, v in counters.items():
            setattr(self, k, v)
