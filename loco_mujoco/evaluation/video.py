"""Videos of an agent's episode beside a translucent "ghost" of the reference motion it imitates.

Both states are drawn in one scene, so that where the policy departs from the motion capture shows at a glance.
The ghost walks ``GHOST_BESIDE_M`` to the agent's left, its root kept level with the agent's (its own travel
would carry a faster reference out of the frame within seconds); its posture and heading are the reference's.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

import mujoco
import numpy as np

GHOST_RGBA = (1.0, 0.55, 0.1, 0.3)  # translucent orange: stands out against the blue floor and sky
GHOST_BESIDE_M = 1.0  # m to the agent's left (of its first heading); None in calls: the reference's own path
CAMERA_AZIMUTH_FROM_HEADING = 60.0


def _check_qpos(model: mujoco.MjModel, qpos: np.ndarray, name: str) -> np.ndarray:
    """``qpos`` as a float (T, nq) array with T >= 1, or a ValueError naming what is wrong."""
    q = np.asarray(qpos, dtype=float)
    if q.ndim != 2 or q.shape[1] != model.nq:
        raise ValueError(f"{name} must have shape (T, nq) with the model's nq={model.nq}, got {q.shape}")
    if len(q) == 0:
        raise ValueError(f"{name} has no states")
    if not np.isfinite(q).all():
        raise ValueError(f"{name} has non-finite values (first at step {int(np.argwhere(~np.isfinite(q))[0, 0])})")
    return q


def _root_body(model: mujoco.MjModel) -> int:
    """The body of the first free joint (the floating base); the world body, which tracks the whole model's
    centre of mass, when there is none."""
    free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    return int(model.jnt_bodyid[free[0]]) if len(free) else 0


def _heading_deg(model: mujoco.MjModel, data: mujoco.MjData, body: int, qpos: np.ndarray) -> float:
    """Direction (degrees from +x) the agent travels over the clip, or its root's x axis if it moves < 0.2 m,
    so that the camera sits beside the walker whichever way the motion goes."""
    free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    if len(free):
        adr = model.jnt_qposadr[free[0]]
        travel = qpos[-1, adr:adr + 2] - qpos[0, adr:adr + 2]
        if np.hypot(*travel) >= 0.2:
            return float(np.degrees(np.arctan2(travel[1], travel[0])))
    x_axis = data.xmat[body].reshape(3, 3)[:, 0]
    return float(np.degrees(np.arctan2(x_axis[1], x_axis[0])))


def iter_frames(model: mujoco.MjModel, agent_qpos: np.ndarray, reference_qpos: np.ndarray | None,
                width: int = 640, height: int = 480, ghost_rgba: Sequence[float] = GHOST_RGBA,
                beside: float | None = GHOST_BESIDE_M) -> Iterator[np.ndarray]:
    """RGB frames (height, width, 3) of ``agent_qpos[t]`` with ``reference_qpos[t]`` as a ghost while there is one.

    Inputs are checked now; the renderer is created at the first frame and closed when the iterator is exhausted
    or closed. The model's offscreen buffer is enlarged if it is smaller than ``width`` x ``height``.
    """
    agent = _check_qpos(model, agent_qpos, "agent_qpos")
    ref = None if reference_qpos is None else _check_qpos(model, reference_qpos, "reference_qpos")
    rgba = np.asarray(ghost_rgba, dtype=np.float32)
    if rgba.shape != (4,) or not ((rgba >= 0) & (rgba <= 1)).all():
        raise ValueError(f"ghost_rgba must be 4 values in [0, 1], got {ghost_rgba!r}")
    if int(width) < 1 or int(height) < 1:
        raise ValueError(f"width and height must be positive, got {width}x{height}")
    return _frames(model, agent, ref, int(width), int(height), rgba, beside)


def _frames(model: mujoco.MjModel, agent: np.ndarray, ref: np.ndarray | None, width: int, height: int,
            rgba: np.ndarray, beside: float | None) -> Iterator[np.ndarray]:
    """The rendering loop of :func:`iter_frames` on checked inputs (a generator, so it starts at the first frame)."""
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    renderer = mujoco.Renderer(model, height, width, max_geom=max(10_000, 3 * model.ngeom + 100))
    try:
        agent_data, ref_data = mujoco.MjData(model), mujoco.MjData(model)
        option, perturb = mujoco.MjvOption(), mujoco.MjvPerturb()
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        camera.trackbodyid = _root_body(model)
        camera.distance = max(2.0 * float(model.stat.extent), 1.5)
        agent_data.qpos[:] = agent[0]
        mujoco.mj_kinematics(model, agent_data)
        # MuJoCo's azimuth is the viewing direction: +60 deg from the heading puts the camera on the walker's
        # right and 30 deg behind its side
        camera.azimuth = _heading_deg(model, agent_data, camera.trackbodyid, agent) + CAMERA_AZIMUTH_FROM_HEADING
        camera.elevation = -15.0
        scene = renderer.scene
        free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
        adr = int(model.jnt_qposadr[free[0]]) if len(free) and beside is not None else None
        if adr is not None:
            yaw = np.radians(camera.azimuth - CAMERA_AZIMUTH_FROM_HEADING)
            offset = beside * np.array([-np.sin(yaw), np.cos(yaw)])
        for t, q in enumerate(agent):
            agent_data.qpos[:] = q
            mujoco.mj_forward(model, agent_data)
            renderer.update_scene(agent_data, camera, option)
            scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False  # shadows cost 5x the frame time in software GL
            if ref is not None and t < len(ref):
                ref_data.qpos[:] = ref[t]
                if adr is not None:
                    ref_data.qpos[adr:adr + 2] = q[adr:adr + 2] + offset
                mujoco.mj_kinematics(model, ref_data)
                n_before = scene.ngeom
                mujoco.mjv_addGeoms(model, ref_data, option, perturb, mujoco.mjtCatBit.mjCAT_DYNAMIC, scene)
                for i in range(n_before, scene.ngeom):
                    geom = scene.geoms[i]
                    geom.rgba[:] = rgba
                    geom.matid = -1  # no texture or reflectance: one flat tint
            yield renderer.render()
    finally:
        renderer.close()


def render_frames(model: mujoco.MjModel, agent_qpos: np.ndarray, reference_qpos: np.ndarray | None,
                  width: int = 640, height: int = 480, ghost_rgba: Sequence[float] = GHOST_RGBA,
                  beside: float | None = GHOST_BESIDE_M) -> list[np.ndarray]:
    """All frames of :func:`iter_frames` as a list (for short clips and tests; videos stream instead)."""
    return list(iter_frames(model, agent_qpos, reference_qpos, width, height, ghost_rgba, beside))


def render_with_reference(model: mujoco.MjModel, agent_qpos: np.ndarray, reference_qpos: np.ndarray | None,
                          path: str | Path, fps: float, width: int = 640, height: int = 480,
                          ghost_rgba: Sequence[float] = GHOST_RGBA, beside: float | None = GHOST_BESIDE_M) -> int:
    """Write an H.264 mp4 of the agent's states with the reference as a translucent ghost; returns the frame count.

    ``agent_qpos`` and ``reference_qpos`` are full-model qpos, shape (T, nq); the camera follows the agent's root.
    """
    from loco_mujoco.demo import write_video

    frames = iter_frames(model, agent_qpos, reference_qpos, width, height, ghost_rgba, beside)
    try:
        return write_video(frames, path, fps)
    finally:
        frames.close()
