"""``make demo``: replay a task's real dataset (UnitreeH1 walking by default) and report on it.

Prints the dataset's provenance and quality figures and the replay statistics and, when offscreen
rendering is available, writes an mp4 of the start of the first trajectory.
"""

from __future__ import annotations

import argparse
import itertools
import math
import numbers
import os
import time
import uuid
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from loco_mujoco import LocoEnv

MAX_FRAMES = 300  # software offscreen rendering costs ~0.2 s a frame: keep the demo short


def write_video(frames: Iterable[np.ndarray], path: str | Path, fps: float) -> int:
    """Write RGB uint8 frames (H, W, 3) as an H.264 mp4 (yuv420p, browser-playable); returns the frame count.

    Frames are streamed to ffmpeg (an iterator keeps long episodes out of memory), odd sizes are padded to even
    ones as yuv420p needs, and the file appears at ``path`` only once it was written completely.
    """
    import imageio_ffmpeg

    path = Path(path)
    if not (isinstance(fps, numbers.Real) and math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    frames = iter(frames)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:8]}.partial.mp4")
        open(tmp, "xb").close()  # probes the folder before any frame is rendered; default file permissions
    except OSError as err:
        raise OSError(f"cannot write video {path}: {err}") from err
    try:
        first = next(frames, None)
        if first is None:
            raise ValueError(f"no frames to write to {path}")
        shape = np.shape(first)
        if len(shape) != 3 or shape[2] != 3 or np.asarray(first).dtype != np.uint8:
            raise ValueError(f"frames must be uint8 RGB arrays of shape (H, W, 3), got {np.asarray(first).dtype} "
                             f"{shape} for {path}")
        h, w = shape[:2]
        pad = ((0, h % 2), (0, w % 2), (0, 0))
        writer = imageio_ffmpeg.write_frames(str(tmp), (w + w % 2, h + h % 2), fps=float(fps), codec="libx264",
                                             pix_fmt_out="yuv420p", macro_block_size=2, ffmpeg_log_level="error",
                                             output_params=["-f", "mp4", "-movflags", "+faststart"])
        writer.send(None)
        n = 0
        try:
            for i, frame in enumerate(itertools.chain([first], frames)):
                frame = np.asarray(frame)
                if frame.shape != shape or frame.dtype != np.uint8:
                    raise ValueError(f"frame {i} is {frame.dtype} {frame.shape}, frame 0 is uint8 {shape} ({path})")
                writer.send(np.ascontiguousarray(np.pad(frame, pad, mode="edge")))
                n += 1
        except OSError as err:  # ffmpeg quit: its message is on stderr
            raise OSError(f"ffmpeg failed writing video {path}: {err}") from err
        finally:
            writer.close()
        if not tmp.is_file() or tmp.stat().st_size == 0:
            raise OSError(f"ffmpeg wrote nothing for video {path}")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    if not path.is_file() or path.stat().st_size == 0:
        raise OSError(f"video {path} is missing or empty after writing")
    return n


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
