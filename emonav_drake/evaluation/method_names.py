"""What a figure calls a benchmark method: old runs' names for earlier defaults.

Runs keep the method names they were made with. Two names changed meaning over the
project's history: "policy" ran whatever file was the default then, and "sac" was the
shipped policy before the planner rename. `method_label` turns those into the variant a
figure should name, judged by the checkpoint file the run recorded; new runs of today's
default keep "policy". Colours are `core/palette.py`'s (`palette.method_colours`).
"""

from __future__ import annotations

from pathlib import PurePath

# The LIP-trained EmoBipedNav (`--planner emobipednav`) was the default policy until the
# Digit route's student replaced it: runs made before call it "policy", and runs made
# before the planner rename "sac" (it is a DAgger student). Figures name it by its file.
SHIPPED_POLICY_FILE = "policy_lgm.pt"
LIP_TRAINED_LABEL = "emobipednav"
# The files earlier defaults were run from as "policy", and the variant each is: the MPC
# route's student was the default until the distilled route's Digit round replaced it.
FORMER_DEFAULTS = {
    SHIPPED_POLICY_FILE: LIP_TRAINED_LABEL,
    "emobipednav_digit_mpc.pt": "emobipednav_digit_mpc",
}


def method_label(name: str, checkpoint: str | None = None) -> str:
    """The name a figure gives a benchmark method: a "policy" or "sac" that ran the file of
    an earlier default is that policy's variant name (`FORMER_DEFAULTS`: the LIP-trained
    "emobipednav", the MPC route's "emobipednav_digit_mpc"; an old run's "sac" without a
    recorded checkpoint is the LIP-trained policy too); today's default `policy` and a
    SAC-trained actor of `--planner sac` keep their names."""
    if name not in ("sac", "policy"):
        return name
    if checkpoint is None:
        return LIP_TRAINED_LABEL if name == "sac" else name
    return FORMER_DEFAULTS.get(PurePath(checkpoint).name, name)
