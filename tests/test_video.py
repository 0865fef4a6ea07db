"""Ghost videos: H.264 output, the reference drawn translucently beside the agent, and clear errors.

conftest.py sets MUJOCO_GL=egl before mujoco is imported; without a working offscreen context the tests skip.
"""

from pathlib import Path

import imageio_ffmpeg
import mujoco
import numpy as np
import pytest

from loco_mujoco.demo import write_video
from loco_mujoco.evaluation.video import render_frames, render_with_reference

W, H = 160, 120


@pytest.fixture(scope="module")
def env_and_states(make_env):
    """The UnitreeH1 walking env and 30 of its dataset's qpos, skipping when offscreen rendering is unavailable."""
    env = make_env("UnitreeH1.walk")
    try:
        mujoco.Renderer(env.model, H, W).close()
    except Exception as err:  # no EGL/OSMesa context on this machine
        pytest.skip(f"offscreen rendering unavailable: {err}")
    qpos, _ = env.dataset_states(slice(0, 30))
    return env, qpos


def read_video(path: Path) -> tuple[dict, int]:
    """The ffmpeg metadata of an mp4 and its number of frames."""
    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    return meta, sum(1 for _ in gen)


def test_video_is_h264_with_every_frame(env_and_states, tmp_path):
    env, qpos = env_and_states
    path = tmp_path / "sub" / "ghost.mp4"
    n = render_with_reference(env.model, qpos[3:23], qpos[:20], path, fps=env.dataset.frequency, width=W, height=H)
    assert n == 20 and path.is_file() and path.stat().st_size > 0
    meta, n_read = read_video(path)
    assert meta["codec"] == "h264" and meta["pix_fmt"].startswith("yuv420p")
    assert meta["size"] == (W, H) and n_read == 20
    assert not list(path.parent.glob(".*partial*")), "the temporary file must not be left behind"


def test_ghost_is_drawn_while_the_reference_lasts(env_and_states):
    env, qpos = env_and_states
    agent, ref = qpos[10:14], qpos[:2]  # the reference ends after two frames
    ghost = render_frames(env.model, agent, ref, width=W, height=H)
    plain = render_frames(env.model, agent, None, width=W, height=H)
    assert len(ghost) == len(plain) == 4 and ghost[0].shape == (H, W, 3) and ghost[0].dtype == np.uint8
    diff = [np.abs(g.astype(int) - p.astype(int)).mean() for g, p in zip(ghost, plain, strict=True)]
    assert min(diff[:2]) > 0.5, f"the ghost barely changes the frames: {diff}"
    assert max(diff[2:]) < 0.1, f"frames after the reference ended should have no ghost: {diff}"


def test_bad_qpos_width_names_nq(env_and_states, tmp_path):
    env, qpos = env_and_states
    nq = env.model.nq
    with pytest.raises(ValueError, match=f"agent_qpos.*nq={nq}"):
        render_frames(env.model, qpos[:, :-1], None, width=W, height=H)
    with pytest.raises(ValueError, match=f"reference_qpos.*nq={nq}"):
        render_with_reference(env.model, qpos, np.zeros((5, nq + 1)), tmp_path / "x.mp4", fps=30)
    assert not (tmp_path / "x.mp4").exists()


def test_write_video_pads_odd_sizes_and_names_unwritable_path(tmp_path):
    frames = [np.full((11, 15, 3), 40 * i, dtype=np.uint8) for i in range(3)]
    assert write_video(iter(frames), tmp_path / "odd.mp4", fps=10) == 3
    meta, n_read = read_video(tmp_path / "odd.mp4")
    assert meta["codec"] == "h264" and meta["size"] == (16, 12) and n_read == 3
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("a file where the video's folder should be")
    bad = blocker / "v.mp4"
    with pytest.raises(OSError, match="not_a_folder"):
        write_video(frames, bad, fps=10)
    with pytest.raises(ValueError, match="no frames"):
        write_video([], tmp_path / "empty.mp4", fps=10)
    with pytest.raises(ValueError, match="uint8"):
        write_video([f.astype(float) for f in frames], tmp_path / "float.mp4", fps=10)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["not_a_folder", "odd.mp4"], "failed writes leave nothing"
