"""``make demo``: replay a task's real dataset (UnitreeH1 walking by default) and report on it.

Prints the dataset's provenance and quality figures and the replay statistics and, when offscreen
rendering is available, writes an mp4 of the start of the first trajectory.
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
    parser.add_argument("--seconds", type=float, default=3.0, help="seconds of the first trajectory in the video")
    parser.add_argument("--video", default="out/demo.mp4", help="mp4 of the replay ('' to skip)")
    args = parser.parse_args(argv)

    env = LocoEnv.make(args.env)
    ds = env.dataset
    meta = ds.metadata
    print(f"{args.env}: {ds.n_trajectories} trajectories, {ds.duration:.1f} s at {ds.frequency:.0f} Hz, "
          f"mean forward speed {meta['mean_forward_speed']:.2f} m/s (the task's target speed)")
    print(f"  sources: {', '.join(s['path'] for s in meta.get('sources', []))}")
    print(f"  licences: {', '.join(meta.get('licences', []))}"
          f"{' (NON-COMMERCIAL)' if meta.get('noncommercial') else ''}")
    q = meta.get("quality", {})
    if q:
        print(f"  quality: foot sliding {q['foot_sliding_mps']:.3f} m/s, penetration "
              f"{1000 * q['ground_penetration_max_m']:.1f} mm, joint limits clipped "
              f"{100 * q['joint_limit_clipped_fraction']:.2f}%")
    t0 = time.perf_counter()
    replay = env.play_trajectory()
    drift = env.play_trajectory_from_velocity()
    print(f"  kinematic replay of all {replay['frames']} frames: {100 * replay['fallen_fraction']:.2f}% would count "
          f"as fallen; velocity integration drifts at most {100 * drift['max_root_drift_per_second']:.2f} cm/s "
          f"({time.perf_counter() - t0:.2f} s)")
    if args.video:
        steps = min(int(args.seconds * ds.frequency), MAX_FRAMES)
        try:
            video = env.play_trajectory(n_episodes=1, n_steps_per_episode=steps, record=True,
                                        video_path=args.video, width=480, height=360)
            print(f"  video of the first {steps} frames written to {video['video']}")
        except Exception as err:  # no OpenGL backend: the statistics above are the demo
            print(f"  no video: offscreen rendering unavailable ({err})")
    env.stop()


if __name__ == "__main__":
    main()
