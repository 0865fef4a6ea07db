"""``make demo``: roll out a random policy on a task and report what happened.

Until the baselines exist this is the main job: it shows the environment working end to end and,
when offscreen rendering is available, writes a video of the first episode.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from loco_mujoco import LocoEnv

MAX_FRAMES = 300  # software offscreen rendering costs ~0.2 s a frame: keep the demo short


def write_video(frames: list[np.ndarray], path: Path, fps: int) -> None:
    """Write RGB frames as an mp4 with OpenCV (installed with mushroom-rl's requirements)."""
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    for frame in frames:
        writer.write(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
    writer.release()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--env", default="UnitreeH1.walk", help="task name, e.g. Talos.walk")
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--video", default="out/demo.mp4", help="mp4 of the first episode ('' to skip)")
    args = parser.parse_args(argv)

    env = LocoEnv.make(args.env, seed=args.seed)
    rng = np.random.default_rng(args.seed)
    n_act = env.info.action_space.shape[0]
    print(f"{args.env}: observation {env.info.observation_space.shape}, action {n_act} ({env.control} control), "
          f"control {1 / env.dt:.0f} Hz, physics {env.model.opt.timestep * 1e3:.1f} ms x {env._n_substeps}")
    frames: list[np.ndarray] = []
    video_error = None
    returns, lengths, falls, steps, sim_time = [], [], 0, 0, 0.0
    for episode in range(args.episodes):
        env.reset()
        ret, length = 0.0, 0
        for _ in range(env.info.horizon):
            action = rng.uniform(-1.0, 1.0, n_act)
            t0 = time.perf_counter()
            _, reward, absorbing, _ = env.step(action)
            sim_time += time.perf_counter() - t0
            ret += reward
            steps += 1
            length += 1
            if episode == 0 and args.video and video_error is None and len(frames) < MAX_FRAMES:
                try:
                    frames.append(env.render_rgb(480, 360))
                except Exception as err:  # no OpenGL backend: report it, keep the rollout going
                    video_error = err
            if absorbing:
                falls += 1
                break
        returns.append(ret)
        lengths.append(length)
    print(f"random policy, {args.episodes} episodes: mean return {np.mean(returns):.2f} "
          f"(task reward, max {env.info.horizon}), mean length {np.mean(lengths):.0f} steps, "
          f"{falls} falls, env.step at {steps / sim_time:.0f} steps/s")
    if frames:
        write_video(frames, Path(args.video), int(round(1 / env.dt)))
        print(f"video of episode 1 ({len(frames)} frames) written to {args.video}")
    elif args.video:
        print(f"no video: offscreen rendering unavailable ({video_error})")
    env.stop()


if __name__ == "__main__":
    main()
