"""Which integrator and physics timestep to use at 100 Hz control: speed vs stability vs accuracy.

For each robot and (integrator, timestep) pair:
- speed: env steps/s with uniform random actions, resets on falls (as in env_throughput.py);
- stability: physics divergences (non-finite state) over those steps, and the largest |qvel| seen;
- accuracy: RMS joint-angle error (rad) and root-height error (mm) against a 0.25 ms implicitfast
  reference over 0.3 s of the same random torques from the home pose (short, before contact chaos
  dominates), and over 1 s of PD control holding the home pose.

The musculoskeletal model gets its own table (``--env HumanoidMuscle.walk``): a "hold" with constant 10 %
excitation instead of PD; a settings column (``coarse``: with ``myo_human.apply_coarse_step_settings``, the
environment's default; ``myo-sim``: the model as myo-sim authors it, through ``restore_myo_sim_settings``); and
the largest hinge speed under bang-bang excitation (every muscle fully on or off at random, a new draw every control
step; see :func:`bang_bang_max_speed`), in the states ``env.step`` returns and inside the control steps. Its
reference is myo-sim's own model at 0.25 ms.

    .venv/bin/python bench/timestep_study.py [--steps 3000] [--env UnitreeH1.walk ...]
    .venv/bin/python bench/timestep_study.py --env HumanoidMuscle.walk [--bang-steps 10000]
    .venv/bin/python bench/timestep_study.py --bang-bang [--env HumanoidMuscle.walk] [--bang-steps 10000]

``--bang-bang`` only runs the bang-bang check on each environment's default settings and prints its largest hinge
speed against the 25 rad/s bound (exit status 1 above it).
"""

from __future__ import annotations

import argparse
import sys
import time

import mujoco
import numpy as np

from loco_mujoco import LocoEnv
from loco_mujoco.core.task_names import environment_class
from loco_mujoco.models.myo_human import restore_myo_sim_settings

INT = mujoco.mjtIntegrator
CONFIGS = [
    ("RK4", INT.mjINT_RK4, 0.001),
    ("Euler", INT.mjINT_EULER, 0.001),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.001),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.002),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.0025),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.005),
]
# The musculoskeletal model, whose per-step cost is dominated by muscle paths: (label, integrator, dt, coarse) where
# coarse applies myo_human.apply_coarse_step_settings (the environment's default) and otherwise myo-sim's values;
# a label ending in "+ reuse" reuses the implicit factorisation within a control step (core/implicit_reuse.py).
MUSCLE_CONFIGS = [
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.001, False),
    ("Euler", INT.mjINT_EULER, 0.002, False),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.002, False),
    ("Euler", INT.mjINT_EULER, 0.0025, False),
    ("Euler", INT.mjINT_EULER, 0.0025, True),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.0025, True),
    ("Euler", INT.mjINT_EULER, 0.01 / 3, False),
    ("Euler", INT.mjINT_EULER, 0.005, False),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.005, False),
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.005, True),
    ("implicitfast + reuse", INT.mjINT_IMPLICITFAST, 0.005, True),  # the environment's default
    ("implicitfast", INT.mjINT_IMPLICITFAST, 0.01, True),
]
REFERENCE = (INT.mjINT_IMPLICITFAST, 0.00025)
SPEED_BOUND = 25.0  # rad/s: largest hinge speed allowed under bang-bang excitation


def env_class(name: str) -> type[LocoEnv]:
    """The environment class of a task name such as ``HumanoidMuscle.walk``, without building it."""
    return environment_class(name.split(".")[0])


def make(name: str, integrator: int, dt: float, control: str | None = None, coarse: bool = True,
         reuse: bool = False) -> LocoEnv:
    """``name`` at ``dt`` (10 ms / dt physics steps per control step) with ``integrator``; muscle models with
    ``coarse`` False get myo-sim's own settings back; ``reuse``: physics steps 2..n reuse the first one's implicit
    factorisation (core/implicit_reuse.py), else exact ``mj_step``."""
    if control == "pd" and "pd" not in env_class(name).CONTROLS:
        control = None  # muscle models: the "hold" run uses constant excitation instead
    env = LocoEnv.make(name, timestep=dt, n_substeps=int(round(0.01 / dt)), control=control, reward_type="none")
    env.model.opt.integrator = integrator
    env.reuse_implicit_factor = reuse
    if env.control == "muscle" and not coarse:
        restore_myo_sim_settings(env.model)
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


def bang_bang_max_speed(name: str, control_steps: int, integrator: int | None = None, dt: float | None = None,
                        coarse: bool = True, seed: int = 0,
                        reuse_implicit_factor: bool | None = None) -> tuple[float, float, str, float]:
    """Hinge speeds under bang-bang excitation: each control step every actuator gets -1 or +1 at random (a muscle
    fully relaxed or fully excited), held for the control step; a fall resets the episode.

    Returns the largest |qvel| of any hinge joint over the states ``env.step`` returns (rad/s; the figure the
    25 rad/s bound applies to), its 99th percentile over control steps, that joint's name, and the largest hinge
    speed inside the control steps too (checked before every physics step through ``mjcb_control``).
    Defaults: the environment's own integrator and timestep.
    """
    cls = env_class(name)
    dt = cls.TIMESTEP if dt is None else dt
    reuse = cls.REUSE_IMPLICIT_FACTOR if reuse_implicit_factor is None else reuse_implicit_factor
    env = make(name, cls.INTEGRATOR if integrator is None else integrator, dt, coarse=coarse, reuse=reuse)
    m, d = env.model, env.data
    hinges = np.array([m.jnt_dofadr[j] for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE])
    rng = np.random.default_rng(seed)
    inside = [0.0]

    def watch(_model: mujoco.MjModel, data: mujoco.MjData) -> None:
        inside[0] = max(inside[0], float(np.abs(data.qvel[hinges]).max()))

    speeds = np.zeros(control_steps)
    worst_dof = np.zeros(control_steps, dtype=int)
    env.reset()
    mujoco.set_mjcb_control(watch)
    try:
        for i in range(control_steps):
            _, _, absorbing, _ = env.step(rng.choice([-1.0, 1.0], size=env.info.action_space.shape[0]))
            hinge_speeds = np.abs(d.qvel[hinges])
            worst_dof[i] = hinges[hinge_speeds.argmax()]
            speeds[i] = hinge_speeds.max()
            if absorbing:
                env.reset()
    finally:
        mujoco.set_mjcb_control(None)
    k = int(speeds.argmax())
    joint = m.joint(int(m.dof_jntid[worst_dof[k]])).name
    return float(speeds[k]), float(np.percentile(speeds, 99)), joint, max(inside[0], float(speeds[k]))


def study(name: str, steps: int, bang_steps: int) -> None:
    ref_env = make(name, *REFERENCE, coarse=False)
    muscle = ref_env.control == "muscle"
    rng = np.random.default_rng(0)
    n_act = ref_env.info.action_space.shape[0]
    short = rng.uniform(-1, 1, size=(30, n_act))
    ref_short = trajectory(ref_env, short)
    ref_pd_env = make(name, *REFERENCE, control="pd", coarse=False)
    hold = np.tile(home_action(ref_pd_env), (100, 1))
    ref_hold = trajectory(ref_pd_env, hold)
    long = rng.uniform(-1, 1, size=(steps, n_act))
    configs = MUSCLE_CONFIGS if muscle else [(*c, True) for c in CONFIGS]
    for label, integrator, dt, coarse in configs:
        reuse = label.endswith("+ reuse")  # physics steps 2..n reuse the first one's factorisation
        env = make(name, integrator, dt, coarse=coarse, reuse=reuse)
        env.reset()
        diverged, max_vel = 0, 0.0
        t0 = time.perf_counter()
        for a in long:
            _, _, absorbing, info = env.step(a)
            diverged += info["physics_diverged"]
            max_vel = max(max_vel, float(np.abs(env.data.qvel).max()))
            if absorbing:
                env.reset()
        sps = steps / (time.perf_counter() - t0)
        e_short = errors(trajectory(env, short), ref_short)
        e_hold = errors(trajectory(make(name, integrator, dt, control="pd", coarse=coarse, reuse=reuse), hold),
                        ref_hold)
        row = f"| {name} | {label} | {dt * 1e3:g} x {int(round(0.01 / dt))} | "
        if muscle:
            bang, _, joint, inside = bang_bang_max_speed(name, bang_steps, integrator, dt, coarse,
                                                         reuse_implicit_factor=reuse)
            row = (f"| {name} | {label} | {'coarse' if coarse else 'myo-sim'} | {dt * 1e3:g} x {int(round(0.01 / dt))}"
                   f" | {sps:,.0f} | {diverged} | {max_vel:.0f} | {bang:.0f} ({joint}) / {inside:.0f} | ")
        else:
            row += f"{sps:,.0f} | {diverged} | {max_vel:.0f} | "
        print(row + f"{e_short[0]:.4f} / {e_short[1]:.2f} | {e_hold[0]:.4f} / {e_hold[1]:.2f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", nargs="*", default=None,
                        help="default: UnitreeH1.walk Talos.walk UnitreeA1.simple (--bang-bang: HumanoidMuscle.walk)")
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--bang-steps", type=int, default=10_000, help="control steps of bang-bang excitation")
    parser.add_argument("--bang-bang", action="store_true",
                        help="only the bang-bang speed check of each environment's default settings")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="--bang-bang: one run per seed")
    parser.add_argument("--reuse-implicit-factor", choices=("on", "off"), default=None,
                        help="--bang-bang: override the environment's REUSE_IMPLICIT_FACTOR (core/implicit_reuse.py)")
    args = parser.parse_args()
    reuse = None if args.reuse_implicit_factor is None else args.reuse_implicit_factor == "on"
    if args.bang_bang:
        failed = False
        for name, seed in ((n, s) for n in args.env or ["HumanoidMuscle.walk"] for s in args.seeds):
            cls = env_class(name)
            t0 = time.perf_counter()
            worst, p99, joint, inside = bang_bang_max_speed(name, args.bang_steps, seed=seed,
                                                            reuse_implicit_factor=reuse)
            ok = worst <= SPEED_BOUND
            failed |= not ok
            reused = cls.REUSE_IMPLICIT_FACTOR if reuse is None else reuse
            print(f"{name} ({mujoco.mjtIntegrator(cls.INTEGRATOR).name}, {cls.TIMESTEP * 1e3:g} ms x "
                  f"{cls.N_SUBSTEPS}{', factorisation reused' if reused else ''}, seed {seed}): "
                  f"{args.bang_steps:,} bang-bang control "
                  f"steps: largest hinge speed {worst:.1f} rad/s ({joint}), 99th percentile {p99:.1f} rad/s, "
                  f"{'within' if ok else 'ABOVE'} the {SPEED_BOUND:g} rad/s bound; inside the control steps "
                  f"(every physics step) {inside:.1f} rad/s ({time.perf_counter() - t0:.0f} s)",
                  flush=True)
        sys.exit(1 if failed else 0)
    names = args.env or ["UnitreeH1.walk", "Talos.walk", "UnitreeA1.simple"]
    header = None
    for name in names:
        muscle = env_class(name).DEFAULT_CONTROL == "muscle"
        if header != muscle:
            if muscle:
                print(f"| environment | integrator | settings | dt (ms) x substeps | env steps/s | diverged | "
                      f"max abs qvel | bang-bang max hinge speed, {args.bang_steps:,} steps: env.step (joint) / "
                      "physics steps | random 0.3 s: joint RMS (rad) / height RMS (mm) | hold 1 s: joint RMS / "
                      "height RMS |")
                print("|---|---|---|---|---|---|---|---|---|---|")
            else:
                print("| environment | integrator | dt (ms) x substeps | env steps/s | diverged | max abs qvel | "
                      "random 0.3 s: joint RMS (rad) / height RMS (mm) | PD hold 1 s: joint RMS / height RMS |")
                print("|---|---|---|---|---|---|---|---|")
            header = muscle
        study(name, args.steps, args.bang_steps)

if __name__ == "__main__":
    main()
