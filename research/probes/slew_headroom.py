"""Where could a learned wheel torque beat the PD law? Slews of greedy + PD on ``Cruise-Hybrid-v0``.

Greedy + PD (``greedy-pd``: greedy's target choice, the env's PD law, k_a = 0.02 N m, k_w = 1 N m s, 1-s
steps) runs ``--episodes`` held-out hours. For every switch of target the script records the slew angle
[deg] (boresight to the new planet's estimated direction), the time [s] until the new planet is first
in the camera's field (``in_field``) and first measured, the time until the pointing error is below
1e-4 rad (20"; settled), and the peak wheel momentum [fraction of capacity]. The lower bound of a slew
is the rest-to-rest bang-bang time at the wheel limits (torque 0.01 N m, momentum 0.5 N m s, mean
inertia 10 kg m^2; ``planetnav_agents.gain.bang_bang_time``) to the field's edge (angle - 8 deg): no
torque law, learned or not, brings the planet into the field sooner. The gap, summed over the
switches of an hour, is the fraction of steps a learned torque could add to the measured ones.

``--agent`` runs another agent instead (any agent spec, e.g. a saved policy ``runs/hybrid/model.zip``) on
``--env-id`` (default ``Cruise-Hybrid-v0``). A slew is then a change of the PD option the agent picks
(its direct-torque option, ``k = P``, keeps the slew under way), and the script also reports how often
the agent picks the direct torque, split by whether the planet it slews to is in the field then, and the
gaps between the last measurement of one planet and the first of another (what any torque law, learned
or not, is judged by: in torque mode, where there is no option, only these are reported).

    .venv/bin/python research/probes/slew_headroom.py --episodes 10
    .venv/bin/python research/probes/slew_headroom.py --episodes 10 --agent runs/hybrid/model.zip
"""

from __future__ import annotations

import argparse
import math

import gymnasium as gym
import numpy as np

import planetnav_env  # noqa: F401
from planetnav_agents import make_agent
from planetnav_agents.gain import SlewModel, bang_bang_time
from planetnav_env.core import layout as L


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--seed", type=int, default=10000)
    ap.add_argument("--agent", default="greedy-pd", help="agent spec or saved model path (default greedy-pd)")
    ap.add_argument("--env-id", default="planetnav/Cruise-Hybrid-v0", help="a 1-s torque or hybrid id")
    args = ap.parse_args()
    if args.episodes < 1:
        raise SystemExit(f"--episodes must be >= 1, got {args.episodes}")
    rows = []
    measured_total = steps_total = 0
    direct_in_field = direct_slewing = 0  # steps on the direct-torque option (hybrid mode)
    gaps: list[int] = []  # steps between the last measurement of one planet and the first of another
    momentum = []  # per step, max |h_w| / capacity
    for ep in range(args.episodes):
        env = gym.make(args.env_id, noise_streams="per_step")
        cfg = env.unwrapped.config
        if cfg.action_mode not in ("hybrid", "torque"):
            raise SystemExit(f"--env-id must name a hybrid or torque id, got {args.env_id!r}")
        hybrid = cfg.action_mode == "hybrid"
        slew = SlewModel.from_config(cfg)
        half_fov = min(cfg.camera.half_fov_rad)
        agent = make_agent(args.agent, env)
        agent.reset(seed=args.seed + ep)
        obs, info = env.reset(seed=args.seed + ep)
        layout = env.unwrapped.layout
        p0, f0 = layout.planets_start, layout.in_field_start
        current, slew_rec = -1, None
        last_planet, last_k = -1, -1
        for k in range(cfg.episode_steps):
            action = np.asarray(agent.act(obs, info))
            # Torque mode has no option: only the measurement gaps below describe it.
            chosen = int(np.argmax(action[: cfg.n_planets + 1])) if hybrid else current
            if chosen == cfg.n_planets:  # direct torque: the slew under way (if any) goes on
                in_field = current >= 0 and obs[f0 + current] > 0.5
                direct_in_field += bool(in_field)
                direct_slewing += not in_field
                chosen = current
            if chosen >= 0 and chosen != current:
                cos0 = float(obs[p0 + L.TARGET_FEATURES * chosen + L.TF_DIR])
                if slew_rec is not None:
                    rows.append(slew_rec)
                angle = math.acos(min(1.0, max(-1.0, cos0)))
                slew_rec = {
                    "angle": angle,
                    "t0": k,
                    "field": None,
                    "measured": None,
                    "settled": None,
                    "h": 0.0,
                    "bound": float(bang_bang_time(max(angle - half_fov, 0.0), slew.accel, slew.rate_max)),
                }
                current = chosen
            obs, _, term, trunc, info = env.step(action)
            measured_total += info["measured"]
            steps_total += 1
            h = float(np.max(np.abs(env.unwrapped.truth["h_w"]))) / cfg.attitude.wheel_momentum_capacity
            momentum.append(h)
            if info["measured"] and 0 <= info["target_index"] < cfg.n_planets:
                if last_planet >= 0 and info["target_index"] != last_planet:
                    gaps.append(k - last_k - 1)
                last_planet, last_k = info["target_index"], k
            if slew_rec is None:
                if term or trunc:
                    break
                continue
            slew_rec["h"] = max(slew_rec["h"], h)
            t = k + 1 - slew_rec["t0"]
            if slew_rec["field"] is None and obs[f0 + current] > 0.5:
                slew_rec["field"] = t
            if slew_rec["measured"] is None and info["measured"] and info["target_index"] == current:
                slew_rec["measured"] = t
            err = math.acos(min(1.0, float(obs[p0 + L.TARGET_FEATURES * current + L.TF_DIR])))
            if slew_rec["settled"] is None and err < 1e-4:
                slew_rec["settled"] = t
            if term or trunc:
                break
        if slew_rec is not None:
            rows.append(slew_rec)
    print(f"{args.episodes} hours of {args.agent} ({args.env_id}, per-step noise, seeds {args.seed}..)")
    g = np.array(gaps, float)
    print(
        f"measured fraction {measured_total / steps_total:.3f}; switches of the measured planet: {len(g)} "
        f"({len(g) / args.episodes:.1f} per hour), gap between them [s]: median "
        f"{np.median(g) if len(g) else math.nan:.0f}, mean {g.mean() if len(g) else math.nan:.0f}; "
        f"wheel momentum [fraction of capacity]: mean {np.mean(momentum):.2f}, max {np.max(momentum):.2f}"
    )
    if hybrid:
        print(
            f"direct-torque option: {(direct_in_field + direct_slewing) / steps_total:.3f} of the steps "
            f"({direct_slewing / steps_total:.3f} with the PD target outside the field, "
            f"{direct_in_field / steps_total:.3f} inside it)"
        )
    # The first "switch" of an episode starts from the initial attitude (counted: it is a slew too).
    done = [r for r in rows if r["field"] is not None and r["angle"] > 2 * half_fov]
    if not done:
        print("no PD-option slew > 16 deg reached the field: no slew statistics")
        return
    ang = np.degrees([r["angle"] for r in done])
    field = np.array([r["field"] for r in done], float)
    bound = np.array([r["bound"] for r in done])
    meas = np.array([r["measured"] if r["measured"] is not None else np.nan for r in done], float)
    settled = np.array([r["settled"] if r["settled"] is not None else np.nan for r in done], float)
    hpk = np.array([r["h"] for r in done])
    print(
        f"PD-option slews > 16 deg: {len(done)} "
        f"({len(done) / args.episodes:.1f} per hour), angle median {np.median(ang):.0f} deg"
    )
    print(
        f"time to the field [s]: PD median {np.median(field):.0f} (mean {field.mean():.0f}); bang-bang bound "
        f"median {np.median(bound):.0f} (mean {bound.mean():.0f}); gap mean {np.mean(field - bound):.0f} s"
    )
    print(
        f"time to the first measurement [s]: median {np.nanmedian(meas):.0f}; to 1e-4 rad (settled): median "
        f"{np.nanmedian(settled):.0f}, never within the hold: {int(np.isnan(settled).sum())}"
    )
    print(
        f"peak wheel momentum during a slew [fraction of capacity]: median {np.median(hpk):.2f}, "
        f"max {hpk.max():.2f}"
    )
    gap_steps = float(np.sum(field - bound)) / args.episodes
    print(f"steps per hour a faster slew could add: {gap_steps:.0f} of 3600 ({gap_steps / 36:.1f} %)")


if __name__ == "__main__":
    main()
