"""Which torch device a command runs on: a `--device` string checked against the hardware.

`resolve_device("cuda")` on a machine without a CUDA GPU is a one-line user error naming
the flag (`DeviceError`), not a failure deep inside torch when the first tensor moves.
Everything that takes `--device` (training, `emonav sim` with a learned policy, SARL's
value network) resolves it here; CPU is always available.
"""

from __future__ import annotations

import torch

from emonav_drake.errors import UserError


class DeviceError(UserError, ValueError):
    """A torch device string is malformed or names hardware this machine does not have."""


def resolve_device(device: str, flag: str = "--device") -> torch.device:
    """`device` as a `torch.device`, checked against the hardware; else `DeviceError`.

    Catches the two mistakes that otherwise surface deep inside torch: a malformed name
    ("bogus") and a GPU that is not there ("cuda" on a CPU-only machine, "cuda:3" on a
    one-GPU machine), so the error blames the flag and not the checkpoint.
    """
    try:
        d = torch.device(device)
    except (RuntimeError, ValueError, TypeError):
        raise DeviceError(
            f"{flag} {device!r}: not a torch device; use cpu, cuda or cuda:N"
        ) from None
    if d.type == "cuda":
        if not torch.cuda.is_available():
            raise DeviceError(
                f"{flag} {device}: no CUDA GPU is available to torch on this machine "
                "(torch.cuda.is_available() is False); use --device cpu"
            )
        if d.index is not None and d.index >= torch.cuda.device_count():
            raise DeviceError(
                f"{flag} {device}: only {torch.cuda.device_count()} CUDA device(s) visible"
            )
    elif d.type == "mps":
        if not torch.backends.mps.is_available():
            raise DeviceError(f"{flag} {device}: the Apple MPS backend is not available here")
    elif d.type != "cpu":
        raise DeviceError(f"{flag} {device}: unsupported device type; use cpu or cuda")
    return d
