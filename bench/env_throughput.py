"""Environment throughput: env.step vs the raw physics it wraps.

Protocol, per environment (default settings): 5000 steps of uniform random actions in [-1, 1] with
termination on and a reset after each fall, timed end to end (env.step + env.reset). Then the same
5000 control steps as raw physics (``env.step_physics()``: ``mj_step(model, data, n_substeps)``, or the
muscle model's reused factorisation) on the same model, replaying the same
controls from the same start states, with ``mj_resetData`` + the start state at the same resets.
Both runs visit identical states (checked). Best of --repeats runs, after one warm-up.

    .venv/bin/python bench/env_throughput.py [--steps 5000] [--repeats 3] [--env UnitreeH1.walk ...]
"""

from __future__ import annotations

import argparse
import platform
import time

import mujoco
import numpy as np

from loco_mujoco import LocoEnv

DEFAULT_ENVS = ["UnitreeH1.walk", "Talos.walk", "UnitreeA1.simple", "Atlas.walk", "HumanoidTorque.walk",
                "HumanoidTorque4Ages.walk.all", "HumanoidMuscle.walk", "HumanoidMuscle4Ages.walk.all"]
# Reference implementation, same protocol and machine type; the 4-size variants are compared with their base.
REFERENCE = {"UnitreeH1": 3193, "Talos": 2231, "UnitreeA1": 2345, "Atlas": 1026, "HumanoidTorque": 1618,
             "HumanoidMuscle": 2647}


def run_env(env: LocoEnv, actions: np.ndarray) -> tuple[float, list[int], np.ndarray]:
    """Seconds for the env loop, the step indices after which it reset, and the final qpos."""
    resets = []
    env.reset()
    t0 = time.perf_counter()
    for i, action in enumerate(actions):
        _, _, absorbing, _ = env.step(action)
        if absorbing:
            env.reset()
            resets.append(i)
    elapsed = time.perf_counter() - t0
    return elapsed, resets, env.data.qpos.copy()


def run_raw(env: LocoEnv, ctrls: np.ndarray, resets: list[int]) -> tuple[float, np.ndarray]:
    """Seconds for the same control sequence as raw physics steps (env.step_physics) with the same resets."""
    m, d = env.model, env.data
    start_qpos = env._init_qpos.copy()
    reset_after = np.zeros(len(ctrls), dtype=bool)
    reset_after[resets] = True
    mujoco.mj_resetData(m, d)
    d.qpos[:] = start_qpos
    mujoco.mj_forward(m, d)
    t0 = time.perf_counter()
    for i in range(len(ctrls)):
        d.ctrl[:] = ctrls[i]
        env.step_physics()  # the physics env.step runs: mj_step, or with the implicit factorisation reused
        if reset_after[i]:
            mujoco.mj_resetData(m, d)
            d.qpos[:] = start_qpos
            mujoco.mj_forward(m, d)
    elapsed = time.perf_counter() - t0
    return elapsed, d.qpos.copy()


def measure(name: str, steps: int, repeats: int, seed: int = 0, reuse_implicit_factor: bool | None = None) -> dict:
    env = LocoEnv.make(name, seed=seed)
    if reuse_implicit_factor is not None:
        env.reuse_implicit_factor = reuse_implicit_factor
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-1.0, 1.0, size=(steps, env.info.action_space.shape[0]))
    ctrls = env.action_to_ctrl(actions)  # what env.step writes to data.ctrl
    run_env(env, actions[:200])  # warm-up
    env_times, raw_times = [], []
    # Mode "all" swaps the body size at each reset: there is no single raw model to replay against.
    resizes = getattr(env, "mode", None) == "all"
    for _ in range(repeats):
        t_env, resets, q_env = run_env(env, actions)
        if resizes:
            env_times.append(t_env)
            raw_times.append(np.nan)
            continue
        t_raw, q_raw = run_raw(env, ctrls, resets)
        if not np.array_equal(q_env, q_raw):
            raise RuntimeError(f"{name}: env and raw runs diverged; the comparison would be unfair")
        env_times.append(t_env)
        raw_times.append(t_raw)
    t_env, t_raw = min(env_times), min(raw_times) if not resizes else np.nan
    return {"env": name, "env_sps": steps / t_env, "raw_sps": steps / t_raw, "ratio": t_env / t_raw,
            "resets": len(resets), "ref": REFERENCE.get(name.split(".")[0].removesuffix("4Ages"))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", nargs="*", default=DEFAULT_ENVS)
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--reuse-implicit-factor", choices=("on", "off"), default=None,
                        help="override the environments' REUSE_IMPLICIT_FACTOR (core/implicit_reuse.py)")
    args = parser.parse_args()
    reuse = None if args.reuse_implicit_factor is None else args.reuse_implicit_factor == "on"
    print(f"# {platform.processor() or platform.machine()}, mujoco {mujoco.__version__}, "
          f"{args.steps} steps, best of {args.repeats}")
    header = (f"| {'environment':<28} | {'env steps/s':>11} | {'raw steps/s':>11} | {'env/raw cost':>12} | "
              f"{'resets':>6} | {'reference':>9} | {'x reference':>11} |")
    print(header)
    print("|" + "|".join("-" * (len(c)) for c in header.split("|")[1:-1]) + "|")
    for name in args.env:
        r = measure(name, args.steps, args.repeats, reuse_implicit_factor=reuse)
        ref = f"{r['ref']:,}" if r["ref"] else "-"
        speedup = f"{r['env_sps'] / r['ref']:.2f}" if r["ref"] else "-"
        raw = f"{r['raw_sps']:>11,.0f}" if np.isfinite(r["raw_sps"]) else f"{'-':>11}"
        ratio = f"{r['ratio']:>12.3f}" if np.isfinite(r["ratio"]) else f"{'-':>12}"
        print(f"| {name:<28} | {r['env_sps']:>11,.0f} | {raw} | {ratio} | "
              f"{r['resets']:>6} | {ref:>9} | {speedup:>11} |", flush=True)


if __name__ == "__main__":
    main()
