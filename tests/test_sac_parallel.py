"""SAC with several environments stepped together: on Ray it equals the serial run, and
an interrupted run resumes bit-for-bit (real LIP envs, real networks, a real local Ray)."""

import pytest

from emonav_drake.learning.run_state import SAC_FORMAT, read_run_state
from emonav_drake.learning.sac_config import SacConfig
from emonav_drake.learning.sac_trainer import train_sac
from tests.state_equality import assert_equal_state


def _cfg(**kw) -> SacConfig:
    base = dict(
        grid_kind="scan",
        num_envs=2,
        total_steps=41,
        random_steps=10,
        replay_size=200,
        batch_size=8,
        hidden=32,
        eval_every=17,
        eval_episodes=1,
        checkpoint_every=15,
        seed=5,
        threads=1,
    )
    return SacConfig(**(base | kw)).validate()


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    agent = train_sac(out, _cfg(), progress=False, parallel=False)
    return out, agent


@pytest.mark.slow
def test_two_envs_step_together_and_evaluate_on_crossings(serial):
    out, _ = serial
    state, _ = read_run_state(out / "checkpoint.pt", SAC_FORMAT)
    # 21 iterations of 2 steps: the run ends at 42, the first multiple of 2 >= 41
    assert state["step"] == 42 == state["replay"]["size"]
    assert len(state["envs"]) == 2 and len(state["running"]) == 2
    rows = (out / "learning_curve.csv").read_text().splitlines()[1:]
    assert [int(r.split(",")[0]) for r in rows] == [18, 34]  # crossings of 17 and 34


@pytest.mark.slow
def test_ray_equals_serial(serial, tmp_path):
    out, agent = serial
    ray_agent = train_sac(tmp_path / "ray", _cfg(), progress=False, parallel=True)
    assert_equal_state(agent.state_dict(), ray_agent.state_dict())
    assert (tmp_path / "ray" / "learning_curve.csv").read_text() == (
        out / "learning_curve.csv"
    ).read_text()


@pytest.mark.slow
def test_an_interrupted_two_env_run_resumes_bit_for_bit(serial, tmp_path):
    _, agent = serial
    train_sac(tmp_path / "run", _cfg(), stop_at=20, progress=False, parallel=False)
    saved, _ = read_run_state(tmp_path / "run" / "checkpoint.pt", SAC_FORMAT)
    assert saved["step"] == 20
    resumed = train_sac(tmp_path / "run", _cfg(), resume=True, progress=False, parallel=False)
    assert_equal_state(agent.state_dict(), resumed.state_dict())
