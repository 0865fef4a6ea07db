"""Edits on an MjSpec before compiling: naming the root, fixing joints, collision filtering, control mode.

All edits work on the spec (MuJoCo's model-editing API), never on XML text.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import mujoco
import numpy as np

ROOT_JOINT = "root"


def name_free_joint(spec: mujoco.MjSpec, name: str = ROOT_JOINT) -> None:
    """Give the (single) free joint a known name: Menagerie models leave it unnamed or name it freely."""
    free = [j for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
    if len(free) != 1:
        raise ValueError(f"expected exactly one free joint in model '{spec.modelname}', found {len(free)}")
    free[0].name = name


_QPOS_WIDTH = {mujoco.mjtJoint.mjJNT_FREE: 7, mujoco.mjtJoint.mjJNT_BALL: 4}
_DOF_WIDTH = {mujoco.mjtJoint.mjJNT_FREE: 6, mujoco.mjtJoint.mjJNT_BALL: 3}


def qpos_width(joint_type: int) -> int:
    """Number of qpos entries of a joint of this type (free 7, ball 4, hinge/slide 1)."""
    return _QPOS_WIDTH.get(mujoco.mjtJoint(int(joint_type)), 1)


def dof_width(joint_type: int) -> int:
    """Number of qvel entries of a joint of this type (free 6, ball 3, hinge/slide 1)."""
    return _DOF_WIDTH.get(mujoco.mjtJoint(int(joint_type)), 1)


def keyframe_qpos(spec: mujoco.MjSpec, key: str | int = 0) -> dict[str, np.ndarray]:
    """Map each joint name to its qpos entries in keyframe ``key`` (by name or index).

    Relies on ``spec.joints`` listing joints in compiled (depth-first) order, as MuJoCo does.
    """
    keys = list(spec.keys)
    if isinstance(key, int):
        frame = keys[key]
    else:
        matches = [k for k in keys if k.name == key]
        if not matches:
            raise ValueError(f"keyframe '{key}' not in model; it has {[k.name for k in keys]}")
        frame = matches[0]
    qpos = np.array([frame.qpos[i] for i in range(len(frame.qpos))])
    out, adr = {}, 0
    for joint in spec.joints:
        width = qpos_width(joint.type)
        out[joint.name] = qpos[adr : adr + width].copy()
        adr += width
    if adr != len(qpos):
        raise ValueError(f"keyframe '{frame.name}' has {len(qpos)} qpos entries, the joints need {adr}")
    return out


def fix_joints(spec: mujoco.MjSpec, names: Iterable[str], angles: Mapping[str, float] | None = None) -> None:
    """Remove hinge/slide joints and their actuators, welding each child body at ``angles[name]`` (default 0).

    The body frame is moved so that the welded pose equals the pose the joint had at that angle.
    """
    names = set(names)
    angles = angles or {}
    for act in list(spec.actuators):
        if act.target in names:
            spec.delete(act)
    for eq in list(spec.equalities):  # e.g. gripper linkages coupling two removed joints
        if eq.type == mujoco.mjtEq.mjEQ_JOINT and (eq.name1 in names or eq.name2 in names):
            spec.delete(eq)
    for joint_name in sorted(names):
        joint = spec.joint(joint_name)
        if joint is None:
            raise ValueError(f"cannot fix joint '{joint_name}': not in model '{spec.modelname}'")
        angle = float(angles.get(joint_name, 0.0))
        if angle != 0.0:
            _bake_joint_displacement(joint, angle)
        spec.delete(joint)
    for key in list(spec.keys):  # keyframes no longer match the shortened qpos
        spec.delete(key)


def _bake_joint_displacement(joint: mujoco.MjsJoint, value: float) -> None:
    body = joint.parent
    axis = np.asarray(joint.axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    body_quat = np.asarray(body.quat, dtype=float)
    body_quat = body_quat / np.linalg.norm(body_quat)
    if joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
        offset = np.zeros(3)
        mujoco.mju_rotVecQuat(offset, axis * value, body_quat)
        body.pos = np.asarray(body.pos) + offset
        return
    if joint.type != mujoco.mjtJoint.mjJNT_HINGE:
        raise ValueError(f"only hinge or slide joints can be fixed, '{joint.name}' is {joint.type}")
    rot = np.zeros(4)
    mujoco.mju_axisAngle2Quat(rot, axis, value)
    anchor = np.asarray(joint.pos, dtype=float)
    rotated_anchor = np.zeros(3)
    mujoco.mju_rotVecQuat(rotated_anchor, anchor, rot)
    shift = np.zeros(3)
    mujoco.mju_rotVecQuat(shift, anchor - rotated_anchor, body_quat)
    new_quat = np.zeros(4)
    mujoco.mju_mulQuat(new_quat, body_quat, rot)
    body.pos = np.asarray(body.pos) + shift
    body.quat = new_quat


def _subtree_bodies(body: mujoco.MjsBody) -> list[mujoco.MjsBody]:
    out, stack = [], [body]
    while stack:
        b = stack.pop()
        out.append(b)
        stack.extend(b.bodies)
    return out


def filter_self_collisions(
    spec: mujoco.MjSpec, left_leg_root: str, right_leg_root: str, floor: str = "floor"
) -> None:
    """Robot geoms touch the floor; the left leg also touches the right leg; all other self-contacts are off.

    Collision bits: 1 = floor, 2 = left leg, 4 = right leg. Contacts within one leg chain or between a leg
    and the pelvis are prevented by the joint limits anyway, and checking them costs more than the rest of
    the physics on mesh-collision robots (Talos: 2x).
    """
    floor_geom = spec.geom(floor)
    if floor_geom is None:
        raise ValueError(f"model '{spec.modelname}' has no floor geom named '{floor}'")

    def colliding(geom: mujoco.MjsGeom) -> bool:
        return geom.name != floor and not (geom.contype == 0 and geom.conaffinity == 0)

    # Set bits while walking the trees: MjSpec element wrappers are recreated on access, so they cannot be
    # compared by identity afterwards.
    for body in _subtree_bodies(spec.worldbody):
        for geom in body.geoms:
            if colliding(geom):
                geom.contype, geom.conaffinity = 1, 0
    for root, bits in ((left_leg_root, (1 | 2, 4)), (right_leg_root, (1 | 4, 2))):
        leg = spec.body(root)
        if leg is None:
            raise ValueError(f"leg root body '{root}' not in model '{spec.modelname}'")
        for body in _subtree_bodies(leg):
            for geom in body.geoms:
                if colliding(geom):
                    geom.contype, geom.conaffinity = bits
    floor_geom.contype, floor_geom.conaffinity = 1, 1


def _joint_range(spec: mujoco.MjSpec, joint_name: str) -> np.ndarray:
    joint = spec.joint(joint_name)
    rng = np.asarray(joint.range, dtype=float)
    if not rng[1] > rng[0]:
        raise ValueError(f"joint '{joint_name}' has no range; a PD target needs one")
    return rng


def torque_range(spec: mujoco.MjSpec, act: mujoco.MjsActuator) -> np.ndarray:
    """The actuator's force limit: forcerange for position servos, ctrlrange x gear for motors."""
    if act.gaintype == mujoco.mjtGain.mjGAIN_FIXED and act.biastype == mujoco.mjtBias.mjBIAS_NONE:
        return np.asarray(act.ctrlrange, dtype=float) * float(act.gear[0])
    rng = np.asarray(act.forcerange, dtype=float)
    if not rng[1] > rng[0]:
        raise ValueError(f"actuator '{act.name}' has no force range to derive a torque limit from")
    return rng


def to_torque_control(spec: mujoco.MjSpec) -> None:
    """Turn every actuator into a direct torque motor whose ctrlrange is its force limit (N m)."""
    for act in spec.actuators:
        torque = torque_range(spec, act)
        act.set_to_motor()
        act.gear[0] = 1.0
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = torque
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE


def to_position_control(spec: mujoco.MjSpec, gains: Mapping[str, tuple[float, float]]) -> None:
    """Turn every actuator into a PD servo on its joint: ctrl is the target angle within the joint range.

    ``gains[joint] = (kp, kd)``; the output torque is clipped at the actuator's original force limit.
    """
    for act in spec.actuators:
        if act.target not in gains:
            raise ValueError(f"no PD gains for joint '{act.target}'; given gains for {sorted(gains)}")
        kp, kd = gains[act.target]
        torque = torque_range(spec, act)
        act.set_to_position(kp=float(kp), kv=float(kd))
        act.gear[0] = 1.0
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = _joint_range(spec, act.target)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = torque
