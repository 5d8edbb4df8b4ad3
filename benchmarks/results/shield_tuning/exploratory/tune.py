import sys, time
import numpy as np, torch; torch.set_num_threads(1)
from emonav_drake.core.metrics import summarize
from emonav_drake.core.navigation import NavigationWorld
from emonav_drake.core.scenario import sample_scenario
from emonav_drake.core.lgm_shield import ShieldParams
from emonav_drake.params import EmoNavConfig, EpisodeParams
from emonav_drake.planners import make_planner, configure_for
from emonav_drake.planners.model_aware import load_response
from emonav_drake.planners.shield import ShieldedPolicy
from emonav_drake.planners.variants import shipped_checkpoint
from emonav_drake.planners.policy import PolicyPlanner

resp, ckpt, margins, first, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
brake = int(sys.argv[6]) if len(sys.argv) > 6 else 1
sm = float(sys.argv[7]) if len(sys.argv) > 7 and sys.argv[7] != "none" else None
pred = sys.argv[8] if len(sys.argv) > 8 else resp
shield_model = load_response(pred)
cfg0 = EmoNavConfig()
response = load_response(resp)
path = shipped_checkpoint(ckpt) if not ckpt.endswith(".pt") else ckpt
for m in margins.split(","):
    pol = PolicyPlanner(path, robot_radius=cfg0.robot.radius)
    cfg, _ = configure_for(pol, cfg0)
    planner = pol if m == "none" else ShieldedPolicy(pol, cfg, response=shield_model, params=ShieldParams(float(m), brake, static_margin=sm))
    recs, t0, inadm = [], time.time(), 0
    for seed in range(first, first + n):
        w = NavigationWorld(sample_scenario(seed, cfg), cfg, goal_radius=EpisodeParams.eval_goal_radius, response=response)
        planner.reset(); out = None
        while out is None:
            u = planner.plan(w.planner_input())
            inadm += m != "none" and not planner.last_admissible
            _, out = w.step(u)
        recs.append(w.record)
    s = summarize(recs)
    fails = [(first + i, r.outcome) for i, r in enumerate(recs) if r.outcome != "success"]
    print(f"{ckpt} resp={resp!r} margin={m} brake={brake} static={sm} pred={pred!r}: SR {s['SR']:.3f} coll {s['collision_rate']:.3f} to {s['timeout_rate']:.3f} NT {s['NT_mean']:.2f} DT {s['DT']} inadm {inadm} ({time.time()-t0:.0f}s) {fails}", flush=True)
