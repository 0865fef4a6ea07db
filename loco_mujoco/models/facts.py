"""Robot facts files (``../shared/robot-facts/*.yaml``) read, validated and turned into an MjSpec.

A facts file describes a robot as a tree of bodies (pose relative to the parent, inertial, joints,
primitive collision shapes) plus torque actuators. We build our own models from it: the six root
coordinates (three slides, three hinges) become one free joint named ``root`` on a Z-up frame, so our
own models behave like the Menagerie ones (same observation layout, same dataset format).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import yaml

from loco_mujoco.models.spec_edit import ROOT_JOINT
from loco_mujoco.rotations import quat_mul, rotate

FACTS_DIR_ENV = "LOCO_MUJOCO_ROBOT_FACTS"
_SHARED_FACTS = Path(__file__).resolve().parents[2].parent / "shared" / "robot-facts"

_BODY_KEYS = {"name", "parent", "pos", "quat", "inertial", "joints", "collision_geoms"}
_INERTIAL_KEYS = {"mass", "pos", "quat", "diaginertia"}
_JOINT_KEYS = {"name", "type", "pos", "axis", "limited", "range", "stiffness", "damping", "armature", "frictionloss"}
_GEOM_KEYS = {"name", "type", "size", "pos", "quat", "friction", "contype", "conaffinity"}
_ACTUATOR_KEYS = {"name", "joint", "gear", "ctrlrange"}
_GEOM_TYPES = {"box": mujoco.mjtGeom.mjGEOM_BOX, "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
               "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE, "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
               "ellipsoid": mujoco.mjtGeom.mjGEOM_ELLIPSOID}
_JOINT_TYPES = {"hinge": mujoco.mjtJoint.mjJNT_HINGE, "slide": mujoco.mjtJoint.mjJNT_SLIDE}


class FactsError(ValueError):
    """A robot facts file is missing, malformed or inconsistent."""


def facts_dir() -> Path:
    """``$LOCO_MUJOCO_ROBOT_FACTS`` if set, else ``../shared/robot-facts`` beside the checkout."""
    return Path(os.environ.get(FACTS_DIR_ENV, _SHARED_FACTS))


def load_facts(name_or_path: str | Path) -> dict[str, Any]:
    """Read and validate a facts file, given as a path or a name in :func:`facts_dir` (``atlas``)."""
    path = Path(name_or_path)
    if path.suffix != ".yaml":
        path = facts_dir() / f"{name_or_path}.yaml"
    if not path.is_file():
        raise FactsError(f"robot facts file {path} not found; set {FACTS_DIR_ENV} to the folder holding "
                         f"atlas.yaml and humanoid_skeleton.yaml")
    try:
        facts = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        raise FactsError(f"{path}: not valid YAML: {err}") from err
    _validate(facts, path)
    return facts


def _check_keys(what: str, entry: Mapping[str, Any], allowed: set[str], path: Path) -> None:
    if not isinstance(entry, Mapping):
        raise FactsError(f"{path}: {what} must be a mapping, got {type(entry).__name__}")
    unknown = set(entry) - allowed
    missing = allowed - set(entry)
    if unknown or missing:
        raise FactsError(f"{path}: {what} has unknown keys {sorted(unknown)} and lacks {sorted(missing)}; "
                         f"expected {sorted(allowed)}")


def _validate(facts: Any, path: Path) -> None:
    if not isinstance(facts, dict) or "bodies" not in facts or "actuators" not in facts:
        raise FactsError(f"{path}: expected a mapping with 'bodies' and 'actuators'")
    seen = {"world"}
    joints = set()
    for body in facts["bodies"]:
        _check_keys(f"body {body.get('name', '?')!r}", body, _BODY_KEYS, path)
        if body["parent"] not in seen:
            raise FactsError(f"{path}: body {body['name']!r} comes before its parent {body['parent']!r}")
        seen.add(body["name"])
        _check_keys(f"inertial of {body['name']!r}", body["inertial"], _INERTIAL_KEYS, path)
        if body["inertial"]["mass"] < 0 or min(body["inertial"]["diaginertia"]) < 0:
            raise FactsError(f"{path}: body {body['name']!r} has a negative mass or inertia")
        for joint in body["joints"]:
            _check_keys(f"joint {joint.get('name', '?')!r}", joint, _JOINT_KEYS, path)
            if joint["type"] not in _JOINT_TYPES:
                raise FactsError(f"{path}: joint {joint['name']!r} has type {joint['type']!r}; "
                                 f"valid: {sorted(_JOINT_TYPES)}")
            joints.add(joint["name"])
        for geom in body["collision_geoms"]:
            _check_keys(f"a collision geom of {body['name']!r}", geom, _GEOM_KEYS, path)
            if geom["type"] not in _GEOM_TYPES:
                raise FactsError(f"{path}: a geom of {body['name']!r} has type {geom['type']!r}; "
                                 f"valid: {sorted(_GEOM_TYPES)}")
    for act in facts["actuators"]:
        _check_keys(f"actuator {act.get('name', '?')!r}", act, _ACTUATOR_KEYS, path)
        if act["joint"] not in joints:
            raise FactsError(f"{path}: actuator {act['name']!r} drives unknown joint {act['joint']!r}")


def spec_from_facts(facts: Mapping[str, Any], model_name: str, rgba: tuple[float, float, float, float] = (
        0.6, 0.6, 0.65, 1.0)) -> mujoco.MjSpec:
    """An MjSpec of the robot in the facts, on a floor named ``floor``, with a free joint named ``root``.

    The root body keeps its world position but its frame is re-expressed Z-up (its rotation is pushed
    into its inertial, geoms and children), so that the free joint's quaternion is identity when upright.
    Collision primitives double as the visual geometry. Actuators are motors with the facts' gear.
    """
    spec = mujoco.MjSpec()
    spec.modelname = model_name
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = True
    spec.compiler.degree = False
    add_scene(spec)
    bodies: dict[str, mujoco.MjsBody] = {}
    roots = [b for b in facts["bodies"] if b["parent"] == "world"]
    if len(roots) != 1:
        raise FactsError(f"expected one root body, found {[b['name'] for b in roots]}")
    root_name = roots[0]["name"]
    root_rot = np.asarray(roots[0]["quat"], dtype=float)
    for fb in facts["bodies"]:
        parent = spec.worldbody if fb["parent"] == "world" else bodies[fb["parent"]]
        pos, quat = np.asarray(fb["pos"], dtype=float), np.asarray(fb["quat"], dtype=float)
        if fb["name"] == root_name:
            quat = np.array([1.0, 0.0, 0.0, 0.0])
        elif fb["parent"] == root_name:  # re-express in the root's Z-up frame
            pos, quat = rotate(root_rot, pos), quat_mul(root_rot, quat)
        frame_rot = root_rot if fb["name"] == root_name else np.array([1.0, 0.0, 0.0, 0.0])
        body = parent.add_body(name=fb["name"], pos=pos, quat=quat)
        bodies[fb["name"]] = body
        inertial = fb["inertial"]
        body.explicitinertial = True
        body.mass = float(inertial["mass"])
        body.ipos = rotate(frame_rot, inertial["pos"])
        body.iquat = quat_mul(frame_rot, inertial["quat"])
        body.inertia = np.asarray(inertial["diaginertia"], dtype=float)
        if fb["name"] == root_name:
            body.add_freejoint(name=ROOT_JOINT)
        else:
            for fj in fb["joints"]:
                body.add_joint(name=fj["name"], type=_JOINT_TYPES[fj["type"]], pos=fj["pos"], axis=fj["axis"],
                               range=fj["range"], limited=(mujoco.mjtLimited.mjLIMITED_TRUE if fj["limited"]
                                                           else mujoco.mjtLimited.mjLIMITED_FALSE),
                               stiffness=fj["stiffness"], damping=fj["damping"], armature=fj["armature"],
                               frictionloss=fj["frictionloss"])
        for i, fg in enumerate(fb["collision_geoms"]):
            size = np.zeros(3)
            size[: len(fg["size"])] = fg["size"]
            name = fg["name"] or f"{fb['name']}_geom{i}"
            body.add_geom(name=name, type=_GEOM_TYPES[fg["type"]], size=size, pos=rotate(frame_rot, fg["pos"]),
                          quat=quat_mul(frame_rot, fg["quat"]), friction=fg["friction"], contype=fg["contype"],
                          conaffinity=fg["conaffinity"], rgba=rgba)
    for fa in facts["actuators"]:
        act = spec.add_actuator(name=fa["name"], target=fa["joint"], trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_motor()
        act.gear[0] = float(fa["gear"])
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = np.asarray(fa["ctrlrange"], dtype=float)
    return spec


def add_scene(spec: mujoco.MjSpec) -> None:
    """A checkered floor named ``floor``, a sky and a light: the scene every own model stands in."""
    spec.visual.headlight.ambient = [0.3, 0.3, 0.3]
    spec.visual.headlight.diffuse = [0.6, 0.6, 0.6]
    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.2, 0.3, 0.4], rgb2=[0.1, 0.2, 0.3], width=300, height=300, mark=mujoco.mjtMark.mjMARK_EDGE,
                     markrgb=[0.8, 0.8, 0.8])
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.3, 0.5, 0.7], rgb2=[0.0, 0.0, 0.0], width=512, height=3072)
    mat = spec.add_material(name="grid", texrepeat=[5, 5], reflectance=0.2)
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    spec.worldbody.add_light(pos=[0, 0, 3.5], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="grid")


def total_mass(facts: Mapping[str, Any]) -> float:
    """Sum of the body masses in the facts."""
    return float(sum(b["inertial"]["mass"] for b in facts["bodies"]))
