"""A policy checkpoint's network as TorchScript (`emonav export`): a file that runs without
this package, e.g. on the robot's computer.

A categorical student is traced as it is (inputs: the uint8 observation stack and the
float32 vector state; output: the scores of the command grid); a SAC actor as its
deterministic action, tanh of the Gaussian's mean (`_ActorMean`).
"""

from __future__ import annotations

from pathlib import Path

import torch

from emonav_drake.atomic_io import atomic_write
from emonav_drake.planners.networks import Actor
from emonav_drake.planners.policy import load_policy, probe_input


def export_torchscript(path: str | Path, out: str | Path) -> Path:
    """Export a checkpoint's network to TorchScript (inputs: uint8 stack, vector state).

    The file is written atomically (a temporary sibling renamed when complete), through a
    file object: a full disk is an `OSError` naming `out` (torch's own file writer would
    abort the process).
    """
    from emonav_drake.atomic_io import check_output_file

    out = check_output_file(out)
    model, meta = load_policy(path)
    example = probe_input(meta)
    scripted = torch.jit.trace(
        model if meta["kind"] == "categorical" else _ActorMean(model), example
    )
    atomic_write(out, lambda f: torch.jit.save(scripted, f), durable=False)
    return out


class _ActorMean(torch.nn.Module):
    def __init__(self, actor: Actor) -> None:
        super().__init__()
        self.actor = actor

    def forward(self, obs: torch.Tensor, state: torch.Tensor) -> torch.Tensor:
        mu, _ = self.actor(obs, state)
        return torch.tanh(mu)
