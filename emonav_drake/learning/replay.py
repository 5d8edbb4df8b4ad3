"""Replay buffer that stores every observation frame once (uint8) and indexes N-frame windows.

A (9, 100, 100) uint8 stack is 90 KB; consecutive stacks share 8 frames, so each
transition stores only the frame indices of its observation and next observation. The
frame ring holds twice the transition capacity (plus a margin), which is more than a
transition still in the buffer can reference (one new frame per step, one per reset).
`state_dict` (the run's checkpoint) holds only the filled transitions and the frames
they refer to: its size grows with the steps stored, not with the capacity.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import torch

if TYPE_CHECKING:
    from emonav_drake.navigation.observations import ObservationKind


class FrameReplayBuffer:
    """Ring buffer of transitions over a ring of frames.

    Args:
        capacity: transitions kept.
        frame_shape: shape of one frame, e.g. (100, 100) (LGM) or (1800,) (LiDAR scan).
        frame_dtype: np.uint8 for grid maps, np.float32 for scans.
        num_frames: N, frames per observation window.
        kind: the observation kind whose stacks are stored: one item per step
            (`ObservationKind.newest`, `frame_shape` = its `item_shape`) and the stacks
            rebuilt from windows of items (`from_items`); None: a frame is the stack's
            last row and a window of N frames is the observation.
    """

    def __init__(
        self,
        capacity: int,
        frame_shape: tuple[int, ...],
        frame_dtype: type,
        num_frames: int,
        kind: ObservationKind | None = None,
    ) -> None:
        self.capacity, self.num_frames = capacity, num_frames
        self.kind = kind
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

    def newest(self, stack: np.ndarray) -> np.ndarray:
        """The frame a buffer keeps of an observation `stack` (its newest item)."""
        return stack[-1] if self.kind is None else self.kind.newest(stack)

    def stack_of(self, windows: np.ndarray) -> np.ndarray:
        """Observations from windows of frames (B, N, *frame_shape)."""
        return windows if self.kind is None else self.kind.from_items(windows)

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
            "obs": t(self.stack_of(self.frames[self.obs_ids[idx]])),
            "state": t(self.state[idx]),
            "action": t(self.action[idx]),
            "reward": t(self.reward[idx]),
            "next_obs": t(self.stack_of(self.frames[self.next_ids[idx]])),
            "next_state": t(self.next_state[idx]),
            "not_done": t(self.not_done[idx]),
        }

    _ROWS = ("obs_ids", "next_ids", "state", "next_state", "action", "reward", "not_done")

    def state_dict(self, windows: Sequence[np.ndarray] = ()) -> dict:
        """The buffer as plain data: its counters and only the part of its arrays in use.

        Transition rows: the `size` filled ones. Frames: the newest `frame_span` frames of
        the ring, oldest first (`frames`, starting at ring position `frame_start`): every
        frame a stored transition or one of `windows` (the running episodes' frame ids)
        refers to. The rest is never read again (not yet written, or overwritten in
        effect) and is restored as zeros, so a resumed run samples exactly the same data.
        A few steps into a run the state is a few steps' worth, not the whole capacity.
        """
        n = self.size
        rows = {k: getattr(self, k)[:n] for k in self._ROWS}  # the whole array once full
        ids = [self.obs_ids[:n].ravel(), self.next_ids[:n].ravel()]
        ids += [np.asarray(w, np.int64).ravel() for w in windows]
        span = int(self._age(np.concatenate(ids), self.next_frame).max(initial=-1)) + 1
        start = (self.next_frame - span) % len(self.frames)
        if start + span <= len(self.frames):
            frames = self.frames[start : start + span]
        else:  # the span wraps around the end of the ring
            frames = np.concatenate([self.frames[start:], self.frames[: self.next_frame]])
        counters = {"next_frame": self.next_frame, "size": self.size, "pos": self.pos}
        return rows | counters | {"frames": frames, "frame_start": start}

    def _age(self, ids: np.ndarray, next_frame: int) -> np.ndarray:
        """How many frames were stored after each frame id (0: the newest)."""
        return (next_frame - 1 - ids) % len(self.frames)

    def load_state_dict(self, st: dict) -> None:
        """Restore `state_dict()`; `ValueError` if it does not fit this buffer.

        Also reads the layout of checkpoints that saved the whole arrays (no
        `frame_start`: `frames` is the ring itself).
        """
        counters = {k: int(st[k]) for k in ("next_frame", "size", "pos")}
        size, ring = counters["size"], len(self.frames)
        if not (
            0 <= counters["next_frame"] < ring
            and 0 <= counters["pos"] < self.capacity
            and 0 <= size <= self.capacity
            and (size == self.capacity or counters["pos"] == size)
        ):
            raise ValueError(f"replay counters {counters} are out of range")
        saved_rows = {len(st[k]) if isinstance(st[k], np.ndarray) else None for k in self._ROWS}
        full = saved_rows == {self.capacity}  # the whole arrays (older checkpoints)
        for k in (*self._ROWS, "frames"):
            mine, theirs = getattr(self, k), st[k]
            if not isinstance(theirs, np.ndarray) or theirs.shape[1:] != mine.shape[1:]:
                raise ValueError(
                    f"replay {k}: saved shape {np.shape(theirs)} does not fit {mine.shape} "
                    "(replay_size, num_frames or the observation differ from the run's)"
                )
            if theirs.dtype != mine.dtype:
                raise ValueError(f"replay {k}: saved dtype {theirs.dtype} != {mine.dtype}")
        if not full and saved_rows != {size}:
            raise ValueError(
                f"replay: saved transition rows {sorted(saved_rows, key=str)} != size {size}"
            )
        frames = st["frames"]
        start = int(st.get("frame_start", 0))
        span = len(frames)
        if "frame_start" not in st and span != ring:
            raise ValueError(f"replay frames: saved {span} frames, the ring holds {ring}")
        if not (0 <= start < ring and span <= ring) or (
            "frame_start" in st and start != (counters["next_frame"] - span) % ring
        ):
            raise ValueError(f"replay frames: {span} frames from {start} do not fit the ring")
        ids = np.concatenate([st["obs_ids"][:size].ravel(), st["next_ids"][:size].ravel()])
        if ids.size and not (
            (ids >= 0).all()
            and (ids < ring).all()
            and (self._age(ids, counters["next_frame"]) < span).all()
        ):
            raise ValueError("replay: a transition refers to a frame that was not saved")
        if span == ring and start == 0:
            self.frames = frames
        else:  # zeros (allocated lazily) and the saved span at its ring positions
            self.frames = np.zeros(self.frames.shape, self.frames.dtype)
            first = min(span, ring - start)
            self.frames[start : start + first] = frames[:first]
            self.frames[: span - first] = frames[first:]
        for k in self._ROWS:
            if full:
                setattr(self, k, st[k])
            else:
                array = np.zeros(getattr(self, k).shape, getattr(self, k).dtype)
                array[:size] = st[k]
                setattr(self, k, array)
        self.next_frame, self.size, self.pos = counters["next_frame"], size, counters["pos"]
