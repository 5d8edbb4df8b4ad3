"""The old home of the numpy maths, kept so that `emonav_drake.core.X` imports still work.

The maths now live in folders named for what they are: `scenarios/`, `crowd/`,
`sensing/`, `robot/`, `navigation/`, `planning/` (and `palette.py` at the top). Importing
`emonav_drake.core.X` gives the module at its new place (the same module object, so
`isinstance` and pickles agree) with a `DeprecationWarning` naming that place.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

# old module name -> its module now
MOVED: dict[str, str] = {
    **{m: f"scenarios.{m}" for m in ("scenario", "scenario_spec", "scenario_families")},
    **{m: f"scenarios.{m}" for m in ("paper_scenario", "walls", "global_route")},
    **{m: f"crowd.{m}" for m in ("crowd", "orca", "orca_lines", "orca_lp", "orca_walls")},
    **{m: f"crowd.{m}" for m in ("pedestrian_routes", "pedestrian_legs", "pedestrian_pose")},
    **{m: f"sensing.{m}" for m in ("lidar", "lidar_faults", "lidar_objects", "lidar_sensor")},
    **{m: f"sensing.{m}" for m in ("leg_detection", "crowd_tracker", "grid_maps")},
    **{m: f"sensing.{m}" for m in ("grid_resolution", "kinematic_maps")},
    **{m: f"robot.{m}" for m in ("lip", "alip", "walking_targets", "step_response", "tracking")},
    "navigation": "navigation.lip_world",
    **{m: f"navigation.{m}" for m in ("observations", "reward", "goal_input", "metrics")},
    **{m: f"navigation.{m}" for m in ("social_metrics", "episode_trace", "emotion_timing")},
    **{m: f"planning.{m}" for m in ("dwa", "mpc_guide", "mpc_model", "mpc_qp", "mpc_response")},
    **{m: f"planning.{m}" for m in ("sarl_state", "lgm_shield", "nearby_labels")},
    "palette": "palette",
}


class _MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds `emonav_drake.core.X` and loads it as the module at its new place."""

    prefix = __name__ + "."

    def find_spec(self, fullname, path=None, target=None):  # noqa: ANN001, ANN201
        if fullname.startswith(self.prefix) and fullname[len(self.prefix) :] in MOVED:
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):  # noqa: ANN001, ANN201
        new = "emonav_drake." + MOVED[spec.name[len(self.prefix) :]]
        warnings.warn(
            f"{spec.name} moved to {new}; import it from there", DeprecationWarning, stacklevel=2
        )
        return importlib.import_module(new)

    def exec_module(self, module):  # noqa: ANN001, ANN201
        pass  # already executed at its new place; the import system files it under both names


if not any(isinstance(f, _MovedModules) for f in sys.meta_path):
    sys.meta_path.append(_MovedModules())


def __getattr__(name: str):  # noqa: ANN202
    """`from emonav_drake.core import X` for a moved module X."""
    if name in MOVED:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
