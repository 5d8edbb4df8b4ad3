import math

import numpy as np
import pytest
import torch

from emonav_drake.learning.config import DaggerConfig
from emonav_drake.learning.dagger_rollouts import run_episode_collect
from emonav_drake.learning.dagger_student import Student
from emonav_drake.learning.demonstrations import Demonstrations, FrameStore, command_index
from emonav_drake.learning.sac import SacAgent
from emonav_drake.learning.sac_config import SacConfig
from emonav_drake.learning.sac_trainer import train_sac
from emonav_drake.navigation.lip_world import NavigationWorld
from emonav_drake.params import EmoNavConfig
from emonav_drake.planners.dwa import DwaPlanner
from emonav_drake.planners.model_aware import load_response
from emonav_drake.planners.mpc import MpcPlanner
from emonav_drake.planners.networks import Actor, Critic, LgmEncoder
from emonav_drake.planners.policy import PolicyError, PolicyPlanner, load_policy, save_policy
from emonav_drake.planners.specs import MpcNearbySpec, MpcSpec, ShieldSpec
from emonav_drake.scenarios.scenario import sample_scenario


def n_params(m):
    return sum(p.numel() for p in m.parameters())


def test_encoder_shapes_and_parameter_counts_match_the_paper():
    enc = LgmEncoder(frames=9, size=100)
    assert enc.sizes == [100, 49, 47, 45, 43]
    assert enc.flat == 32 * 43 * 43 == 59_168
    out = enc(torch.zeros(2, 9, 100, 100, dtype=torch.uint8))
    assert out.shape == (2, 50) and out.abs().max() <= 1.0  # tanh
    convs = (9 * 9 * 32 + 32) + 3 * (32 * 9 * 32 + 32)
    assert n_params(enc) == convs + (59_168 * 50 + 50) + 2 * 50  # conv + FC + LayerNorm
    hidden = 1024
    q = (50 + 4 + 2) * hidden + hidden + hidden * hidden + hidden + hidden + 1
    assert n_params(Critic(enc)) == n_params(enc) + 2 * q
    a = (50 + 4) * hidden + hidden + hidden * hidden + hidden + hidden * 4 + 4
    assert n_params(Actor(LgmEncoder())) == n_params(enc) + a
    assert LgmEncoder(pool=2).sizes == [50, 24, 22, 20, 18]


def _batch(b=4, size=100, frames=9):
    g = torch.Generator().manual_seed(0)
    return {
        "obs": torch.randint(0, 256, (b, frames, size, size), dtype=torch.uint8, generator=g),
        "state": torch.randn(b, 4, generator=g),
        "action": torch.rand(b, 2, generator=g) * 2 - 1,
        "reward": torch.randn(b, 1, generator=g),
        "next_obs": torch.randint(0, 256, (b, frames, size, size), dtype=torch.uint8, generator=g),
        "next_state": torch.randn(b, 4, generator=g),
        "not_done": torch.ones(b, 1),
    }


def test_encoder_is_trained_by_the_critic_only():
    cfg = SacConfig(hidden=32, pool=4, grid_size=100)
    agent = SacAgent(cfg, (0.4, 0.2))
    convs = agent.critic.encoder.convs
    assert agent.actor.encoder.convs[0].weight is convs[0].weight  # tied
    b = _batch()
    # actor loss: no gradient reaches the shared convs
    pi, logp, _ = agent.actor.sample(b["obs"], b["state"], detach_encoder=True)
    q1, q2 = agent.critic(b["obs"], b["state"], pi, detach_encoder=True)
    (logp - torch.min(q1, q2)).mean().backward()
    assert all(p.grad is None for p in convs.parameters())
    assert agent.actor.trunk[0].weight.grad is not None
    # critic loss: gradients reach them
    q1, _ = agent.critic(b["obs"], b["state"], b["action"])
    q1.mean().backward()
    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in convs.parameters())
    # a full update changes the convs only through the critic optimiser
    before = convs[0].weight.detach().clone()
    agent.update(_batch())
    assert not torch.equal(before, convs[0].weight)


def _tiny_cfg(**kw):
    base = dict(
        total_steps=120,
        random_steps=40,
        replay_size=500,
        batch_size=8,
        hidden=32,
        pool=4,
        eval_every=60,
        eval_episodes=1,
        checkpoint_every=50,
        seed=3,
        threads=1,
    )
    base.update(kw)
    return SacConfig(**base)


@pytest.mark.slow
def test_tiny_sac_run_resumes_bit_for_bit(tmp_path):
    cfg = _tiny_cfg(total_steps=300, random_steps=100, eval_every=150)
    full = train_sac(tmp_path / "full", cfg, progress=False)
    assert (tmp_path / "full" / "checkpoint.pt").is_file()
    assert (tmp_path / "full" / "learning_curve.csv").read_text().count("\n") == 3  # header+2
    train_sac(tmp_path / "split", cfg, stop_at=173, progress=False)  # interrupted mid-episode
    resumed = train_sac(tmp_path / "split", cfg, resume=True, progress=False)
    a, b = full.state_dict(), resumed.state_dict()
    for key in ("critic", "critic_target", "actor"):
        for name, tensor in a[key].items():
            assert torch.equal(tensor, b[key][name]), f"{key}.{name} differs"
    assert torch.equal(a["log_alpha"], b["log_alpha"]) and a["updates"] == b["updates"] > 0
    # the written policy loads and acts within the bounds
    planner = PolicyPlanner(tmp_path / "full" / "policy.pt")
    u = planner.act(np.zeros((9, 100, 100), np.uint8), np.array([8.0, 0.0]), np.zeros(2))
    assert 0 <= u[0] <= 0.4 and abs(u[1]) <= 0.2


@pytest.mark.slow
def test_scan_variant_runs(tmp_path):
    cfg = _tiny_cfg(grid_kind="scan", total_steps=60, random_steps=30, eval_every=60)
    agent = train_sac(tmp_path / "scan", cfg, progress=False)
    assert agent.updates == 30


@pytest.mark.slow
def test_a_distillation_step_lowers_the_imitation_loss_on_held_out_labels():
    torch.manual_seed(0)
    env_cfg = EmoNavConfig()
    expert = DwaPlanner(env_cfg)
    cfg = DaggerConfig(pool=4, hidden=64, lr=1e-3)
    student = Student(cfg, env_cfg, expert.candidates)
    rng = np.random.default_rng(0)
    train, held = Demonstrations(FrameStore(100)), Demonstrations(FrameStore(100))
    for i in range(4):
        w = NavigationWorld(sample_scenario(10**6 + i, env_cfg), env_cfg, goal_radius=0.2)
        run_episode_collect(w, expert, None, 1.0, train, rng)
    w = NavigationWorld(sample_scenario(10**6 + 99, env_cfg), env_cfg, goal_radius=0.2)
    run_episode_collect(w, expert, None, 1.0, held, rng)

    def held_loss():
        with torch.no_grad():
            return float(student.loss(held.store.frames, *held.arrays()))

    before = held_loss()
    student.train(train, 150, 32, rng, "test")
    assert held_loss() < 0.8 * before
    assert before == pytest.approx(math.log(len(expert.candidates)), rel=0.15)  # ~uniform


def test_policy_checkpoint_errors_are_clear(tmp_path):
    with pytest.raises(PolicyError, match="does not exist"):
        load_policy(tmp_path / "none.pt")
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint at all")
    with pytest.raises(PolicyError, match="not a readable"):
        load_policy(bad)
    torch.save({"format": "something-else"}, bad)
    with pytest.raises(PolicyError, match="emonav-policy"):
        load_policy(bad)
    enc = {"type": "lgm", "frames": 9, "size": 100, "pool": 4}
    model = Actor(LgmEncoder(9, 100, pool=4), hidden=16)
    meta = {
        "kind": "gaussian",
        "encoder": enc,
        "hidden": 16,
        "observation": {"grid_kind": "lgm", "num_frames": 9, "grid_size": 100},
        "bounds": [0.4, 0.2],
    }
    good = tmp_path / "good.pt"
    save_policy(good, model, meta)
    planner = PolicyPlanner(good)
    with pytest.raises(PolicyError, match=r"\(9, 100, 100\)"):
        planner.act(np.zeros((1, 100, 100), np.uint8), np.zeros(2), np.zeros(2))
    save_policy(bad, model, meta | {"hidden": 32})  # metadata disagrees with the weights
    with pytest.raises(PolicyError, match="do not match"):
        load_policy(bad)


def test_policy_drives_the_drake_diagram_within_bounds(tmp_path):
    from emonav_drake.diagrams.navigation import run_episode
    from emonav_drake.planners import configure_for, make_planner

    torch.manual_seed(1)
    cfg = EmoNavConfig()
    cfg.episode.max_steps = 8
    meta = {
        "kind": "gaussian",
        "encoder": {"type": "lgm", "frames": 4, "size": 60, "pool": 2},
        "hidden": 16,
        "observation": {"grid_kind": "lgm", "num_frames": 4, "grid_size": 60},
        "bounds": [0.4, 0.2],
    }
    path = tmp_path / "p.pt"
    save_policy(path, Actor(LgmEncoder(4, 60, pool=2), hidden=16), meta)
    planner = make_planner("sac", cfg, checkpoint=path)
    cfg, kind = configure_for(planner, cfg)  # the diagram's LGM builder follows the checkpoint
    assert (cfg.lidar.num_frames, cfg.lidar.grid_size, kind) == (4, 60, "lgm")
    record, log = run_episode(sample_scenario(3, cfg), cfg, planner, grid_kind=kind, trace=True)
    cmds = np.array(log.commands)
    assert len(cmds) == record.steps == 8
    assert (cmds[:, 0] >= 0).all() and (cmds[:, 0] <= 0.4).all()
    assert (np.abs(cmds[:, 1]) <= 0.2).all()


@pytest.mark.slow
def test_shipped_policy_navigates(tmp_path):
    """`emonav sim --planner policy` works out of the box and the policy reaches the goal."""
    import json

    from emonav_drake.cli import main

    out = tmp_path / "r.json"
    outcomes = []
    for seed in range(6):
        assert main(["sim", "--planner", "policy", "--seed", str(seed), "--json", str(out)]) == 0
        outcomes.append(json.loads(out.read_text())["outcome"])
    assert outcomes.count("success") >= 5, outcomes


def test_torchscript_export_matches_the_checkpoint(tmp_path):
    from emonav_drake.cli import main
    from emonav_drake.planners.policy import DEFAULT_POLICY

    out = tmp_path / "policy.ts"
    assert main(["export", "--out", str(out)]) == 0
    scripted = torch.jit.load(str(out))
    model, _ = load_policy(DEFAULT_POLICY)
    g = torch.Generator().manual_seed(0)
    obs = (torch.rand(1, 9, 100, 100, generator=g) < 0.03).to(torch.uint8) * 255
    state = torch.tensor([[0.8, 0.1, 1.0, -0.5]])
    with torch.no_grad():
        assert torch.allclose(scripted(obs, state), model(obs, state), atol=1e-5)


@pytest.mark.slow
def test_drlvo_variant_observation_and_training(tmp_path):
    from emonav_drake.sensing.kinematic_maps import pedestrian_velocity_map

    # A pedestrian 2 m ahead walking to the robot's left at 1 m/s (robot heading +90°).
    vmap = pedestrian_velocity_map(
        np.zeros(2), math.pi / 2, np.array([[0.0, 2.0]]), np.array([[-1.0, 0.0]]), 0.3
    )
    row, col = int((2.0 + 6.0) / 0.12), int((6.0 - 0.0) / 0.12)
    assert vmap[0, row, col] == 128 and vmap[1, row, col] == 255  # v_x 0, v_y +1 m/s
    assert (vmap != 128).any(axis=0).sum() == pytest.approx(math.pi * 0.3**2 / 0.12**2, rel=0.3)
    cfg = _tiny_cfg(grid_kind="drlvo", num_frames=1, total_steps=60, random_steps=30, eval_every=60)
    agent = train_sac(tmp_path / "drlvo", cfg, progress=False)
    assert agent.updates == 30 and agent.critic.encoder.convs[0].in_channels == 3


@pytest.mark.slow
def test_lndnl_variant_shares_its_lstm_and_trains(tmp_path):
    cfg = _tiny_cfg(
        grid_kind="scan", encoder="lstm", total_steps=60, random_steps=30, eval_every=60
    )
    agent = train_sac(tmp_path / "lndnl", cfg, progress=False)
    assert agent.actor.encoder.lstm is agent.critic.encoder.lstm
    assert agent.updates == 30
    planner = PolicyPlanner(tmp_path / "lndnl" / "policy.pt")
    assert planner.meta["encoder"]["type"] == "scan_lstm"


def test_planner_names_say_what_the_policy_is(tmp_path, capsys):
    """`policy` runs the shipped DAgger student and says so; `sac` is kept for SAC actors:
    without a checkpoint, or with a DAgger student's, it is refused naming `policy`."""
    from emonav_drake.cli import main
    from emonav_drake.diagrams.trials import method_specs
    from emonav_drake.planners.policy import DEFAULT_POLICY, describe_policy, load_policy

    _, meta = load_policy(DEFAULT_POLICY, "cpu")
    assert describe_policy(meta).startswith("DAgger student")
    cfg = tmp_path / "short.yaml"
    cfg.write_text("episode: {max_steps: 2}\n")
    assert main(["sim", "--planner", "policy", "--config", str(cfg)]) == 0
    assert "planner policy: DAgger student" in capsys.readouterr().out
    for extra in ([], ["--checkpoint", str(DEFAULT_POLICY)]):
        assert main(["sim", "--planner", "sac", "--config", str(cfg), *extra]) == 2
        err = capsys.readouterr().err
        assert "--planner policy" in err and "DAgger student" in err, err
    with pytest.raises(ValueError, match="SAC-trained checkpoint"):
        method_specs("sac")
    with pytest.raises(ValueError, match="not a SAC actor"):
        method_specs("sac", [f"sac={DEFAULT_POLICY}"])
    assert method_specs("policy")[0].checkpoint == str(DEFAULT_POLICY)


def test_an_mpc_expert_labels_every_state_with_its_nearest_grid_command():
    """The MPC expert of a route (`DaggerConfig.expert = "mpc"`) in the calibrated world:
    each label is the grid command nearest to what the real MPC plans there."""
    env_cfg = EmoNavConfig()
    env_cfg.episode.max_steps = 12
    grid = DwaPlanner(env_cfg).candidates
    response = load_response("digit")
    demos = Demonstrations(FrameStore(100))

    def world():
        return NavigationWorld(
            sample_scenario(10**6 + 3, env_cfg), env_cfg, goal_radius=0.2, response=response
        )

    expert = MpcSpec().build(env_cfg)
    run_episode_collect(world(), expert, None, 1.0, demos, np.random.default_rng(0), grid=grid)
    mpc, w, labels = MpcPlanner(env_cfg), world(), []
    while True:
        labels.append(command_index(grid, mpc.plan(w.planner_input())))
        if w.step(grid[labels[-1]])[1] is not None:
            break
    assert demos.labels == labels and len(labels) == 12
    assert len(set(labels)) > 1  # it steers, not one constant command


def test_a_route_starts_from_a_shipped_variant_by_name(tmp_path, monkeypatch):
    """`init_policy` (DAgger) and `--init` (fine-tuning) take a shipped variant's name: the
    student starts with that file's weights; a variant without a file is refused, naming
    how to train it."""
    from emonav_drake.learning.config import DaggerConfig
    from emonav_drake.learning.dagger_student import Student
    from emonav_drake.params import ConfigError
    from emonav_drake.planners.variants import VARIANTS, PolicyVariant, resolve_policy_file

    path = resolve_policy_file("emobipednav_digit_mpc")
    assert path == VARIANTS["emobipednav_digit_mpc"].checkpoint
    assert resolve_policy_file("shipped") == VARIANTS["emobipednav"].checkpoint
    model, meta = load_policy(path)
    student = Student(DaggerConfig(), EmoNavConfig(), np.asarray(meta["commands"]))
    student.load_weights("emobipednav_digit_mpc")
    for k, v in model.state_dict().items():
        assert torch.equal(student.model.state_dict()[k].cpu(), v.cpu()), k
    # every variant of this version is shipped: one that is not, as a later one would be
    unshipped = "not_trained"
    monkeypatch.setitem(
        VARIANTS, unshipped, PolicyVariant(unshipped, "X", "y", "policies/not_trained.pt")
    )
    assert not VARIANTS[unshipped].is_shipped
    with pytest.raises(ConfigError, match=f"init_policy {unshipped}: .*emonav train --variant"):
        student.load_weights(unshipped)


def test_an_mpc_expert_with_clearance_keeps_more_room():
    """`MpcSpec.clearance` widens the MPC expert's collision and discomfort
    margins by exactly that much (the caller's configuration untouched), and the real MPC
    then walks another path: seed 10⁶ + 6 takes 56 steps without clearance, more with it."""
    env_cfg = EmoNavConfig()
    before = (env_cfg.mpc.collision_margin, env_cfg.mpc.discomfort_margin)
    wide = MpcSpec(clearance=0.15).build(env_cfg)
    assert (env_cfg.mpc.collision_margin, env_cfg.mpc.discomfort_margin) == before
    assert wide.config.mpc.collision_margin == pytest.approx(before[0] + 0.15)
    assert wide.config.mpc.discomfort_margin == pytest.approx(before[1] + 0.15)
    assert MpcSpec().build(env_cfg).config is env_cfg

    def walk(expert) -> tuple[str, int]:
        world = NavigationWorld(
            sample_scenario(10**6 + 6, env_cfg), env_cfg, goal_radius=0.2, grid_kind=None
        )
        steps, outcome = 0, None
        while outcome is None:
            outcome = world.step(expert.plan(world.planner_input()))[1]
            steps += 1
        return outcome, steps

    plain, widened = walk(MpcPlanner(env_cfg)), walk(wide)
    assert plain[0] == widened[0] == "success"
    assert widened[1] > plain[1]
    with pytest.raises(Exception, match="expert.clearance = 1.5 is out of range"):
        DaggerConfig(expert=MpcSpec(clearance=1.5)).validate()


def test_a_shield_expert_labels_with_the_registered_shielded_policy():
    """A `ShieldSpec` expert: in the calibrated world the labels are the
    commands of `policy_shield_digit` (the default policy behind the LGM shield with
    Digit's response), step for step; on seed 10⁶ + 34 the shield overrides the bare
    policy within 12 steps, so the labels are not the policy's own choices."""
    from emonav_drake.planners import make_planner

    env_cfg = EmoNavConfig()
    env_cfg.episode.max_steps = 12
    response = load_response("digit")

    def world():
        return NavigationWorld(
            sample_scenario(10**6 + 34, env_cfg), env_cfg, goal_radius=0.2, response=response
        )

    expert = ShieldSpec(checkpoint="emobipednav_digit_mpc", response="digit").build(env_cfg)
    grid = expert.policy.commands
    demos = Demonstrations(FrameStore(100))
    run_episode_collect(world(), expert, None, 1.0, demos, np.random.default_rng(0), grid=grid)
    shielded, w = make_planner("policy_shield_digit", env_cfg), world()
    labels, overridden = [], 0
    while True:
        obs = w.planner_input()
        labels.append(command_index(grid, shielded.plan(obs)))
        overridden += labels[-1] != command_index(grid, shielded.policy.plan(obs))
        if w.step(grid[labels[-1]])[1] is not None:
            break
    assert demos.labels == labels and len(labels) == 12
    assert overridden > 0


def test_a_shield_expert_needs_a_policy_to_shield():
    from emonav_drake.params import ConfigError

    with pytest.raises(ConfigError, match=r"!ShieldSpec \{\} needs the policy it wraps"):
        DaggerConfig(expert=ShieldSpec()).validate()
    route = DaggerConfig(expert=ShieldSpec(), init_policy="shipped").validate()
    assert route.teacher() == ShieldSpec(checkpoint="shipped")  # it wraps the start policy
    assert route.expert == ShieldSpec()  # the configuration itself unchanged


def test_soft_labels_of_one_hot_targets_are_the_hard_loss_mirrored_or_not():
    """`Student.loss_on_stacks` with soft labels: one-hot targets give exactly the hard
    cross-entropy, with half the batch mirrored (the target columns permuted as the
    labels are); a spread target gives another loss."""
    env_cfg = EmoNavConfig()
    cfg = DaggerConfig(hidden=16, pool=4)
    student = Student(cfg, env_cfg, DwaPlanner(env_cfg).candidates)
    rng = np.random.default_rng(5)
    stacks = (rng.random((6, 9, 100, 100)) < 0.05).astype(np.uint8)
    states = rng.normal(size=(6, 4)).astype(np.float32)
    labels = rng.integers(0, 99, 6)
    mirror = np.array([True, False, True, False, True, False])
    one_hot = np.eye(99, dtype=np.float32)[labels]
    with torch.no_grad():
        hard = student.loss_on_stacks(stacks, states, labels, mirror)
        soft = student.loss_on_stacks(stacks, states, labels, mirror, one_hot)
        spread = student.loss_on_stacks(
            stacks, states, labels, mirror, np.full((6, 99), 1 / 99, np.float32)
        )
    assert soft.item() == pytest.approx(hard.item(), rel=1e-6)
    assert spread.item() != pytest.approx(hard.item(), rel=1e-3)
    assert (labels == one_hot.argmax(axis=1)).all()  # the inputs were not changed in place


def test_an_mpc_nearby_expert_walks_the_policys_best_command_next_to_the_mpcs():
    """An `MpcNearbySpec` expert in the calibrated world, real MPC (Digit's
    response) and real default policy: at every step the walked command lies within one
    grid step of the MPC's in both components, it is the policy's best-scored such command,
    and the soft label is the policy's softmax renormalised on exactly those commands; with
    a reach wider than the grid the expert is the bare policy."""
    from emonav_drake.planning.nearby_labels import nearby_mask

    env_cfg = EmoNavConfig()
    response = load_response("digit")
    world = NavigationWorld(
        sample_scenario(10**6 + 34, env_cfg), env_cfg, goal_radius=0.2, response=response
    )
    expert = MpcNearbySpec(checkpoint="shipped", cells=1).build(env_cfg)
    wide = MpcNearbySpec(checkpoint="shipped", cells=10).build(env_cfg)
    policy, grid = expert.policy, expert.policy.commands
    steps, moved_off = 0, 0
    for _ in range(15):
        obs = world.planner_input()
        u = expert.plan(obs)
        near = nearby_mask(grid, expert.last_mpc_command, 1)
        assert (np.abs(u - expert.last_mpc_command) <= [0.05 + 1e-9, 0.04 + 1e-9]).all()
        scores = policy.command_scores(obs.lgm_stack, policy.goal_state(obs), obs.last_command)
        i = command_index(grid, u)
        assert near[i] and scores[i] == scores[near].max()
        p = expert.last_distribution
        np.testing.assert_allclose(p.sum(), 1.0)
        assert (p[~near] == 0).all() and int(np.argmax(p)) == i
        np.testing.assert_array_equal(wide.plan(obs), policy.plan(obs))
        moved_off += not np.array_equal(u, policy.plan(obs))
        steps += 1
        if world.step(u)[1] is not None:
            break
    assert steps >= 10 and moved_off > 0  # the MPC moved the policy off its own choice


def test_nearby_labels_reject_what_they_cannot_use():
    from emonav_drake.params import ConfigError
    from emonav_drake.planning.nearby_labels import grid_steps, nearby_mask, restricted_softmax

    grid = np.array([[0.0, -0.1], [0.0, 0.0], [0.2, 0.0], [0.4, 0.1]])
    np.testing.assert_allclose(grid_steps(grid), [0.2, 0.1])
    assert nearby_mask(grid, [0.2, 0.0], 0).tolist() == [False, False, True, False]
    assert nearby_mask(grid, [0.4, 0.1], 1).tolist() == [False, False, True, True]
    assert nearby_mask(grid, [5.0, 5.0], 1).tolist() == [False, False, False, True]  # nearest
    with pytest.raises(ValueError, match="cells"):
        nearby_mask(grid, [0.0, 0.0], -1)
    with pytest.raises(ValueError, match="one value"):
        grid_steps(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="at least one"):
        restricted_softmax(np.zeros(4), np.zeros(4, bool))
    with pytest.raises(ConfigError, match="MpcNearbySpec .* needs the policy it wraps"):
        DaggerConfig(expert=MpcNearbySpec()).validate()
    with pytest.raises(ConfigError, match="soft_labels needs a ShieldSpec or MpcNearbySpec"):
        DaggerConfig(expert=MpcSpec(), soft_labels=True).validate()


def test_a_shielded_mpc_nearby_expert_chooses_only_what_the_shield_admits():
    """`MpcNearbySpec.shielded`: the MPC's neighbourhood is cut to the commands the policy's own LGM
    shield admits; the label is the policy's softmax on what is left (or, where nothing is,
    the shield's distribution), and on seed 10⁶ + 34 the shield removes nearby commands."""
    from emonav_drake.planning.lgm_shield import shield_distribution
    from emonav_drake.planning.nearby_labels import nearby_mask

    env_cfg = EmoNavConfig()
    response = load_response("digit")
    world = NavigationWorld(
        sample_scenario(10**6 + 34, env_cfg), env_cfg, goal_radius=0.2, response=response
    )
    expert = MpcNearbySpec(checkpoint="emobipednav_digit_mpc", shielded=True).build(env_cfg)
    policy, grid, r = expert.policy, expert.policy.commands, env_cfg.robot.radius
    memory, cut = expert.initial_memory(), 0
    for _ in range(20):
        obs = world.planner_input()
        scores = policy.command_scores(obs.lgm_stack, policy.goal_state(obs), obs.last_command)
        gaps, _, _ = expert.shield.gaps(obs, obs.lgm_stack, scores, memory.shield)
        u, memory = expert.plan_with_memory(obs, memory)
        near = nearby_mask(grid, expert.last_mpc_command, 1)
        safe = near & (gaps >= r)
        i = command_index(grid, u)
        if safe.any():
            assert safe[i] and scores[i] == scores[safe].max()
        else:
            np.testing.assert_allclose(
                expert.last_distribution, shield_distribution(scores, gaps, r)
            )
        cut += bool((near & ~safe).any())
        if world.step(u)[1] is not None:
            break
    assert cut > 0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["policy_mpc_digit", "policy_mpc_shield_digit"])
def test_the_mpc_steered_planners_run_a_seeded_episode_on_both_plants(sim_on_both_plants, name):
    """By name through `emonav sim`: a whole LIP episode and 6 Digit steps, twice each to
    the same record (the MPC's warm start and the shield's memory are per episode)."""
    records = sim_on_both_plants(["--planner", name], 11)
    assert records["lip"]["outcome"] in ("success", "collision", "timeout")
    assert records["digit"]["steps"] == 6 and records["digit"]["path_length"] > 0.3
