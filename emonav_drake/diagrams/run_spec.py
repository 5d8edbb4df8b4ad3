"""A run spec: everything that decides a navigation run's result, as one typed record.

`RunSpec` holds the plant, the full resolved configuration, the methods (each a
registered planner's name and, for a learned one, its checkpoint and the checkpoint's
SHA-256), the seeds, the scene when it is a fixed one (a scenario file, in full), the
emotion estimate and the planner modules of the user's own — and nothing that does not
decide the result (Meshcat, progress bars, output paths, the torch device). `emonav sim
--json` and `emonav eval --json` write it under "spec", a benchmark's `settings.json`
too; `--spec FILE` on `sim`, `eval` and `benchmark` runs it again (FILE: such a JSON,
or the spec alone in YAML or JSON), and the same spec gives the same records.

It is a dataclass of the package's typed YAML (`typed_yaml`: Drake's typed loader, every
field checked and named), written as plain data with `run_spec_plain` and read back with
`load_run_spec`. Its annotations are real types (no postponed evaluation in this
module): Drake's YAML loader reads them.

    spec = load_run_spec("a.json")            # a sim's --json, or a spec file
    runner = TrialRunner(spec.benchmark_spec())
    planner, config, grid_kind = runner.planner(spec.methods[0].name)
    scenario = spec.scenario_of(spec.first_seed)
"""

import dataclasses as dc
from pathlib import Path

from emonav_drake.config_fields import setting
from emonav_drake.diagrams.plants import DEFAULT_PLANT, PLANTS
from emonav_drake.params import ConfigError, EmoNavConfig, dump_config
from emonav_drake.perception.noisy_emotions import EmotionEstimateParams
from emonav_drake.provenance import sha256_file
from emonav_drake.scenarios.scenario import MAX_SEED, Scenario, sample_scenario
from emonav_drake.typed_yaml import dump_typed_yaml, from_plain, load_typed_yaml, to_plain

FORMAT = 1
# a spec is a few kB, a sim's --json with its trajectory a few MB; a larger file is no record
MAX_RECORD_BYTES = 100_000_000


@dc.dataclass
class MethodSpec:
    """One compared method: a planner kind and, for learned policies, the checkpoint."""

    name: str = setting("", "the method's name: a registered planner, or a policy of one's own")
    planner: str = setting(
        "", "the planner kind that builds it: dwa, mpc, policy, sarl, … (`PlannerKind.runs_as`)"
    )
    checkpoint: str | None = setting(None, "a learned method's checkpoint file")
    checkpoint_sha256: str | None = setting(None, "the checkpoint's SHA-256 when the run began")
    observation: str = setting("state", 'what the method sees: "state" (DWA, MPC) or its grid kind')


@dc.dataclass
class BenchmarkSpec:
    """What a worker needs to run any trial of the benchmark."""

    methods: list[MethodSpec]
    plant: str
    config_yaml: str
    emotion_estimate_yaml: str | None = None
    # planner modules from outside the package (`planners/plugins.py`): each worker imports
    # them before building a planner
    planner_modules: list[str] = dc.field(default_factory=list)

    def method(self, name: str) -> MethodSpec:
        for m in self.methods:
            if m.name == name:
                return m
        raise KeyError(name)


@dc.dataclass
class RunSpec:
    """What decides a navigation run's result (module docstring)."""

    format: int = setting(FORMAT, "the spec's format", "", (FORMAT, FORMAT))
    plant: str = setting(DEFAULT_PLANT, "the robot: lip (the paper's LIP) or digit")
    methods: list[MethodSpec] = setting([], "the methods (sim, eval: one)")
    first_seed: int = setting(0, "the seed of the first episode", "", (0, MAX_SEED))
    episodes: int = setting(1, "episodes (trials per method), seeds first_seed, …", "", (1, None))
    setting_name: str = setting("", "the --setting or --config file's name; labels only")
    scene_name: str = setting("", "the fixed scene's name (a scenario file's stem); labels only")
    scenario: Scenario | None = setting(
        None, "a fixed scene (a scenario file, in full); absent: each seed's scene is drawn"
    )
    emotion_estimate: EmotionEstimateParams | None = setting(
        None, "the perceived emotions; absent: the simulator's own"
    )
    planner_modules: list[str] = setting([], "planner modules of the user's own to import")
    config: EmoNavConfig = setting(doc="the resolved configuration", factory=EmoNavConfig)

    def benchmark_spec(self) -> BenchmarkSpec:
        """The `BenchmarkSpec` of this run: what a `diagrams.trials.TrialRunner` builds its
        planners and requests from."""
        estimate = None if self.emotion_estimate is None else dump_typed_yaml(self.emotion_estimate)
        return BenchmarkSpec(
            methods=list(self.methods),
            plant=self.plant,
            config_yaml=dump_config(self.config),
            emotion_estimate_yaml=estimate,
            planner_modules=list(self.planner_modules),
        )

    def scenario_of(self, seed: int) -> Scenario:
        """The scene of `seed`: the fixed scene (a copy), else the one drawn from `seed`
        in the configuration's family."""
        import copy

        if self.scenario is not None:
            return copy.deepcopy(self.scenario)
        return sample_scenario(seed, self.config)

    def check(self, where: str = "spec") -> "RunSpec":
        """Raise `ConfigError` naming `where` and the field if the spec cannot run here as
        it ran: an unknown plant or planner, an invalid configuration, scene or estimate,
        a seed range beyond 64 bits, or a checkpoint that is missing or has changed."""
        from emonav_drake.planners import is_registered
        from emonav_drake.planners.plugins import import_planner_modules

        def refuse(what: str) -> ConfigError:
            return ConfigError(f"{where}: {what}")

        if self.plant not in PLANTS:
            raise refuse(f"plant {self.plant!r} is unknown: one of {', '.join(PLANTS)}")
        if not self.methods:
            raise refuse("methods: none given")
        if self.first_seed + self.episodes - 1 > MAX_SEED:
            raise refuse(f"first_seed + episodes - 1 must be at most {MAX_SEED}")
        import_planner_modules(self.planner_modules)
        for m in self.methods:
            if m.checkpoint is None and not is_registered(m.name):
                raise refuse(f"methods: {m.name!r} is no registered planner (emonav planners)")
            if m.checkpoint is not None:
                path = Path(m.checkpoint)
                if not path.is_file():
                    raise refuse(f"the checkpoint of {m.name}, {path}, is not here")
                now = sha256_file(path) if m.checkpoint_sha256 is not None else None
                if now != m.checkpoint_sha256:
                    raise refuse(
                        f"the checkpoint of {m.name}, {path}, has changed since the run "
                        f"(sha256 {m.checkpoint_sha256[:12]}… then, {now[:12]}… now)"
                    )
        try:
            self.config.validate()
            if self.scenario is not None:
                cfg = self.config
                radius = max(cfg.episode.goal_radius, cfg.episode.eval_goal_radius)
                self.scenario.validate(cfg.robot.radius, cfg.crowd.pedestrian_radius, radius)
            if self.emotion_estimate is not None:
                self.emotion_estimate.validate()
        except ConfigError as e:
            raise refuse(str(e)) from None
        return self


def is_settings(data: dict) -> bool:
    """Whether a JSON object has a benchmark's `settings.json` fields."""
    return {"format", "planners", "methods", "config_yaml"} <= set(data)


def run_spec_plain(spec: RunSpec) -> dict:
    """The spec as plain data (JSON-ready): the "spec" of a record."""
    return to_plain(spec)


def read_record(path: Path, where: str) -> dict | None:
    """The JSON object of the file `path` (read once), or None when the file is not JSON
    (a YAML spec); `ConfigError` naming `where` for a file that is no record."""
    if not path.is_file():
        return None  # the YAML loader names what is missing
    if path.stat().st_size > MAX_RECORD_BYTES:
        raise ConfigError(f"{where}: {path.stat().st_size} bytes; not a run's record")
    raw = path.read_bytes()
    if not raw.lstrip().startswith(b"{"):
        return None
    from emonav_drake.json_input import parse_json

    return parse_json(raw, where)


def spec_from_record(data: dict, where: str) -> RunSpec:
    """The `RunSpec` of a JSON object: a record's "spec" (`sim --json`, `eval --json`) or
    a spec itself; checked (`RunSpec.check`). A benchmark's settings are refused here,
    naming the command that reads them."""
    if is_settings(data):
        raise ConfigError(
            f"{where}: a benchmark's settings.json; `emonav benchmark --spec "
            f"{where.removeprefix('--spec ')} --out DIR` runs it again"
        )
    data = data.get("spec", data)
    if not isinstance(data, dict):
        raise ConfigError(f'{where}: its "spec" is not a mapping')
    try:
        spec = from_plain(RunSpec, data)
    except ConfigError as e:
        raise ConfigError(f"{where}: {e}") from None
    return spec.check(where)


def load_run_spec(path: str | Path) -> RunSpec:
    """The `RunSpec` of `path` (checked: `RunSpec.check`): a JSON object with a "spec"
    (`emonav sim --json`, `emonav eval --json`), or a spec alone in JSON or YAML.
    `ConfigError` naming the file and field otherwise."""
    path = Path(path)
    where = f"--spec {path}"
    data = read_record(path, where)
    if data is not None:
        if not isinstance(data, dict):
            raise ConfigError(f"{where}: expected a JSON object")
        return spec_from_record(data, where)
    try:
        spec = load_typed_yaml(RunSpec, path=path)  # its errors name the file
    except ConfigError as e:
        raise ConfigError(f"--spec: {e}") from None
    return spec.check(where)
