"""Which integrator and physics timestep to use at 100 Hz control: speed vs stability vs accuracy.

For each robot and (integrator, timestep) pair:
- speed: env steps/s with uniform random actions, resets on falls (as in env_throughput.py);
- stability: physics divergences (non-finite state) over those steps, and the largest |qvel| seen;
- accuracy: RMS joint-angle error (rad) and root-height error (mm) against a 0.25 ms implicitfast
  reference over 0.3 s of the same random torques from the home pose (short, before contact chaos
  dominates), and over 1 s of PD control holding the home pose.

    .venv/bin/python bench/timestep_study.py [--steps 3000]
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from loco_mujoco import LocoEnv

INT = mujoco.mjtIntegrator
CONFIGS = [
    ("RK4", INT.mjINT_RK4, 0.001),
    ("Euler", INT.mjINT_EULER, 0.001),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.001),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.002),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.0025),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.005),
]
# Extra settings tried for the musculoskeletal model, whose per-step cost is dominated by muscle paths.
MUSCLE_CONFIGS = [
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.001),
    ("Euler", INT.mjINT_EULER, 0.002),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.002),
    ("Euler", INT.mjINT_EULER, 0.0025),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.0025),
    ("Euler", INT.mjINT_EULER, 0.01 / 3),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.01 / 3),
    ("Euler", INT.mjINT_EULER, 0.005),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.005),
]
REFERENCE = (INT.mjINT_IMPLICITFAST, 0.00025)


def make(name: str, integrator: int, dt: float, control: str | None = None) -> LocoEnv:
    if control == "pd" and "pd" not in LocoEnv.make(name, reward_type="none").CONTROLS:
        control = None  # muscle models: the "hold" run uses constant excitation instead
    env = LocoEnv.make(name, timestep=dt, n_substeps=int(round(0.01 / dt)), control=control, reward_type="none")
    env.model.opt.integrator = integrator
    return env


def trajectory(env: LocoEnv, actions: np.ndarray) -> np.ndarray:
    env.reset()
    out = []
    for a in actions:
        env.step(a)
        out.append(env.data.qpos.copy())
    return np.array(out)


def home_action(env: LocoEnv) -> np.ndarray:
    """PD targets of the home pose; for muscle models (no PD) a constant 10% co-contraction."""
    m = env.model
    if env.control == "muscle":
        return np.full(m.nu, -0.8)
    env.reset()
    home = np.array([env.data.joint(m.actuator(i).trnid[0]).qpos[0] for i in range(m.nu)])
    return env.ctrl_to_action(home)


def errors(traj: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    joints = np.sqrt(np.mean((traj[:, 7:] - ref[:, 7:]) ** 2))
    height = np.sqrt(np.mean((traj[:, 2] - ref[:, 2]) ** 2)) * 1e3
    return float(joints), float(height)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--env", nargs="*", default=["UnitreeH1.walk", "Talos.walk", "UnitreeA1.simple"])
    parser.add_argument("--steps", type=int, default=3000)
    args = parser.parse_args()
    print("| environment | integrator | dt (ms) x substeps | env steps/s | diverged | max abs qvel | "
          "random 0.3 s: joint RMS (rad) / height RMS (mm) | PD hold 1 s: joint RMS / height RMS |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.env:
        ref_env = make(name, *REFERENCE)
        rng = np.random.default_rng(0)
        n_act = ref_env.info.action_space.shape[0]
        short = rng.uniform(-1, 1, size=(30, n_act))
        ref_short = trajectory(ref_env, short)
        ref_pd_env = make(name, *REFERENCE, control="pd")
        hold = np.tile(home_action(ref_pd_env), (100, 1))
        ref_hold = trajectory(ref_pd_env, hold)
        long = rng.uniform(-1, 1, size=(args.steps, n_act))
        for label, integrator, dt in (MUSCLE_CONFIGS if ref_env.control == "muscle" else CONFIGS):
            env = make(name, integrator, dt)
            env.reset()
            diverged, max_vel = 0, 0.0
            t0 = time.perf_counter()
            for a in long:
                _, _, absorbing, info = env.step(a)
                diverged += info["physics_diverged"]
                max_vel = max(max_vel, float(np.abs(env.data.qvel).max()))
                if absorbing:
                    env.reset()
            sps = args.steps / (time.perf_counter() - t0)
            e_short = errors(trajectory(env, short), ref_short)
            e_hold = errors(trajectory(make(name, integrator, dt, control="pd"), hold), ref_hold)
            print(f"| {name} | {label} | {dt * 1e3:g} x {int(round(0.01 / dt))} | {sps:,.0f} | {diverged} | "
                  f"{max_vel:.0f} | {e_short[0]:.4f} / {e_short[1]:.2f} | {e_hold[0]:.4f} / {e_hold[1]:.2f} |",
                  flush=True)


if __name__ == "__main__":
    main()
