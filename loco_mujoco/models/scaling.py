"""Geometric body scaling on an MjSpec: a smaller or larger body of the same build.

With height ratio ``f``: lengths scale with ``f``, masses with ``f**3`` (same density), inertias with
``f**5``, and joint torques, muscle forces and joint stiffness/damping with ``f**2`` (force scales with
muscle cross-section). Muscle-tendon lengths follow the geometry exactly: every attachment point scales
with ``f``, so each actuator's length range scales with ``f`` too, which is what the compiler would
recompute from the scaled geometry.
"""

from __future__ import annotations

import mujoco
import numpy as np

_MUSCLE_FORCE = 2  # gainprm/biasprm index of the peak isometric force of a muscle


def _scale_attr(obj: object, name: str, factor: float) -> None:
    setattr(obj, name, np.asarray(getattr(obj, name), dtype=float) * factor)


def scale_spec(spec: mujoco.MjSpec, factor: float) -> None:
    """Scale every body below the world (not the floor) by height ratio ``factor``, in place."""
    if not (np.isfinite(factor) and factor > 0):
        raise ValueError(f"scale factor must be a positive number, got {factor}")
    f, f2, f3, f5 = factor, factor**2, factor**3, factor**5
    for body in spec.bodies:
        if body.name == "world":  # by name: MjSpec wrappers are recreated on access, so `is` cannot tell
            continue
        _scale_attr(body, "pos", f)
        _scale_attr(body, "ipos", f)
        _scale_attr(body, "mass", f3)
        _scale_attr(body, "inertia", f5)
        if np.any(np.asarray(body.fullinertia)):
            _scale_attr(body, "fullinertia", f5)
        for geom in body.geoms:
            _scale_attr(geom, "pos", f)
            if geom.type != mujoco.mjtGeom.mjGEOM_MESH:
                _scale_attr(geom, "size", f)
            fromto = np.asarray(geom.fromto, dtype=float)
            if np.all(np.isfinite(fromto)) and np.any(fromto):
                geom.fromto = fromto * f
            if geom.mass > 0:
                geom.mass = geom.mass * f3
        for site in body.sites:
            _scale_attr(site, "pos", f)
            _scale_attr(site, "size", f)
        for joint in body.joints:
            _scale_attr(joint, "pos", f)
            if joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
                _scale_attr(joint, "range", f)
            _scale_attr(joint, "stiffness", f2)
            _scale_attr(joint, "damping", f2)
            _scale_attr(joint, "frictionloss", f2)
            _scale_attr(joint, "armature", f5)
        for cam in body.cameras:
            _scale_attr(cam, "pos", f)
    for tendon in spec.tendons:
        _scale_attr(tendon, "springlength", f)
        if tendon.limited == mujoco.mjtLimited.mjLIMITED_TRUE or np.any(np.asarray(tendon.range)):
            _scale_attr(tendon, "range", f)
        _scale_attr(tendon, "stiffness", f)  # force per length: f^2 / f
        _scale_attr(tendon, "damping", f)
    for mesh in spec.meshes:
        _scale_attr(mesh, "scale", f)
    for act in spec.actuators:
        _scale_actuator(act, f)
    for eq in spec.equalities:
        _scale_equality(spec, eq, f)
    for key in spec.keys:
        _scale_key(spec, key, f)


def _scale_actuator(act: mujoco.MjsActuator, f: float) -> None:
    f2 = f * f
    if act.dyntype == mujoco.mjtDyn.mjDYN_MUSCLE or act.gaintype == mujoco.mjtGain.mjGAIN_MUSCLE:
        gain, bias = np.array(act.gainprm, dtype=float), np.array(act.biasprm, dtype=float)
        if gain[_MUSCLE_FORCE] < 0:
            raise ValueError(f"muscle {act.name!r} derives its force from 'scale'; give an explicit force to scale it")
        gain[_MUSCLE_FORCE] *= f2
        bias[_MUSCLE_FORCE] *= f2
        act.gainprm, act.biasprm = gain, bias
        _scale_attr(act, "lengthrange", f)
        return
    if act.trntype == mujoco.mjtTrn.mjTRN_JOINT:
        gear = np.array(act.gear, dtype=float)
        gear[0] *= f2  # a motor's torque per unit control
        act.gear = gear
        _scale_attr(act, "forcerange", f2)
    else:
        raise ValueError(f"actuator {act.name!r}: scaling supports joint motors and muscles only")


def _scale_equality(spec: mujoco.MjSpec, eq: mujoco.MjsEquality, f: float) -> None:
    """Joint couplings y = sum c_i x^i: a slide coordinate carries a length (scale f), a hinge an angle."""
    if eq.type != mujoco.mjtEq.mjEQ_JOINT:
        data = np.array(eq.data, dtype=float)
        if eq.type in (mujoco.mjtEq.mjEQ_CONNECT, mujoco.mjtEq.mjEQ_WELD):
            data[:6] *= f  # anchors
            eq.data = data
        return
    sy = f if spec.joint(eq.name1).type == mujoco.mjtJoint.mjJNT_SLIDE else 1.0
    sx = f if eq.name2 and spec.joint(eq.name2).type == mujoco.mjtJoint.mjJNT_SLIDE else 1.0
    data = np.array(eq.data, dtype=float)
    data[:5] = data[:5] * sy / sx ** np.arange(5)
    eq.data = data


def _scale_key(spec: mujoco.MjSpec, key: mujoco.MjsKey, f: float) -> None:
    qpos = np.array(key.qpos, dtype=float)
    if qpos.size == 0:
        return
    adr = 0
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            qpos[adr:adr + 3] *= f
            adr += 7
        elif joint.type == mujoco.mjtJoint.mjJNT_BALL:
            adr += 4
        else:
            if joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
                qpos[adr] *= f
            adr += 1
    key.qpos = qpos
