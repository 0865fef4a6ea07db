"""Author our own MJCF models (Atlas, the torque-driven human skeleton) from the robot facts files.

The generated XML files are committed under ``loco_mujoco/models/<robot>/`` so that users need no facts
files; ``python -m loco_mujoco.models.authoring`` regenerates them, and a test checks that the committed
files equal what the facts give. Everything that the facts leave open (the human's collision shapes,
the home pose, colours) is decided here, in code.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from loco_mujoco.models.facts import load_facts, spec_from_facts
from loco_mujoco.models.posture import lowest_point

MODELS_DIR = Path(__file__).resolve().parent
OWN_MODELS = {
    "atlas": ("atlas", MODELS_DIR / "atlas" / "atlas.xml"),
    "humanoid_torque": ("humanoid_skeleton", MODELS_DIR / "humanoid" / "humanoid_torque.xml"),
}

# Atlas home: knees slightly bent (hips and ankles compensate) so the PD stance has room to balance.
ATLAS_HOME = {"hip_flexion_l": 0.15, "hip_flexion_r": 0.15, "knee_angle_l": -0.3, "knee_angle_r": -0.3,
              "ankle_angle_l": 0.15, "ankle_angle_r": 0.15}


def _capsule(body: mujoco.MjsBody, name: str, start: Any, end: Any, radius: float, rgba: Any) -> None:
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=np.concatenate([start, end]),
                  size=[radius, 0, 0], rgba=rgba)


def _box(body: mujoco.MjsBody, name: str, center: Any, half: Any, rgba: Any) -> None:
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=center, size=half, rgba=rgba)


def _child_pos(spec: mujoco.MjSpec, child: str) -> np.ndarray:
    return np.asarray(spec.body(child).pos, dtype=float)


def add_human_collision_shapes(spec: mujoco.MjSpec) -> None:
    """Capsule segments and box feet for the skeleton (the facts have bone meshes only, which we omit).

    Body frames below the pelvis are Y-up (OpenSim); each long bone gets a capsule from its joint to the
    next joint. The foot box spans heel to toe joint with its sole 1.5 cm below the calcaneus origin, the
    toe box continues it: with all joints at zero both soles lie flat on the ground.
    """
    skin, bone = (0.85, 0.7, 0.6, 1.0), (0.75, 0.6, 0.5, 1.0)
    pelvis = spec.body("pelvis")  # Z-up (re-expressed root): x forward, y left, z up
    _capsule(pelvis, "pelvis_geom", [-0.07, -0.085, 0.0], [-0.07, 0.085, 0.0], 0.08, skin)
    torso = spec.body("torso")
    _capsule(torso, "torso_geom", [0.0, 0.08, 0.0], [0.0, 0.38, 0.0], 0.13, skin)
    torso.add_geom(name="head_geom", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[0.0, 0.62, 0.0], size=[0.1, 0, 0],
                   rgba=skin)
    for s in ("r", "l"):
        sign = 1.0 if s == "r" else -1.0  # lateral is +z in the right leg's Y-up frame
        _capsule(spec.body(f"femur_{s}"), f"femur_{s}_geom", [0, -0.02, 0], _child_pos(spec, f"tibia_{s}") * 0.95,
                 0.06, bone)
        _capsule(spec.body(f"tibia_{s}"), f"tibia_{s}_geom", [0, -0.03, 0], _child_pos(spec, f"talus_{s}") * 0.9,
                 0.045, bone)
        toes = _child_pos(spec, f"toes_{s}")
        _box(spec.body(f"calcn_{s}"), f"foot_{s}", [toes[0] / 2 - 0.015, 0.0, sign * 0.005],
             [toes[0] / 2 + 0.015, 0.015, 0.045], skin)
        _box(spec.body(f"toes_{s}"), f"toes_{s}_geom", [0.03, -0.015 - toes[1] + 0.0075, sign * 0.005],
             [0.03, 0.0075, 0.045], skin)
        _capsule(spec.body(f"humerus_{s}"), f"humerus_{s}_geom", [0, -0.02, 0], _child_pos(spec, f"ulna_{s}") * 0.95,
                 0.04, skin)
        _capsule(spec.body(f"radius_{s}"), f"forearm_{s}_geom", [0, -0.02, 0], _child_pos(spec, f"hand_{s}") * 0.95,
                 0.033, skin)
        _box(spec.body(f"hand_{s}"), f"hand_{s}_geom", [0, -0.07, 0], [0.012, 0.07, 0.04], skin)


def set_home(spec: mujoco.MjSpec, angles: Mapping[str, float]) -> None:
    """Add keyframe ``home``: the given joint angles (others 0), root upright at the height where the lowest
    collision point touches the floor."""
    model = spec.compile()
    data = mujoco.MjData(model)
    qpos = np.zeros(model.nq)
    qpos[3] = 1.0
    for name, value in angles.items():
        qpos[model.joint(name).qposadr[0]] = value
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    floor = model.geom("floor").id
    colliding = [g for g in range(model.ngeom) if g != floor and (model.geom_contype[g] or model.geom_conaffinity[g])]
    qpos[2] = -lowest_point(model, data, colliding)
    spec.add_key(name="home", qpos=qpos)


def author_atlas(facts: Mapping[str, Any]) -> mujoco.MjSpec:
    """Atlas from its facts: primitives as collision and looks, home pose with slightly bent knees."""
    spec = spec_from_facts(facts, "atlas", rgba=(0.55, 0.57, 0.62, 1.0))
    for side in ("l", "r"):
        for g in spec.body(f"{side}_foot").geoms:
            g.rgba = [0.25, 0.25, 0.28, 1.0]
    set_home(spec, ATLAS_HOME)
    return spec


def author_humanoid_torque(facts: Mapping[str, Any]) -> mujoco.MjSpec:
    """The human skeleton from its facts plus designed capsules and box feet; home is standing straight."""
    spec = spec_from_facts(facts, "humanoid_torque")
    add_human_collision_shapes(spec)
    set_home(spec, {})
    return spec


_AUTHORS = {"atlas": author_atlas, "humanoid_torque": author_humanoid_torque}


def authored_xml(model: str, facts_path: str | Path | None = None) -> str:
    """The MJCF text of one of our own models, generated from its facts file."""
    facts_name, _ = OWN_MODELS[model]
    spec = _AUTHORS[model](load_facts(facts_path or facts_name))
    return spec.to_xml()


def own_model_path(model: str) -> Path:
    """The committed MJCF file of one of our own models."""
    if model not in OWN_MODELS:
        raise ValueError(f"unknown own model {model!r}; valid: {', '.join(OWN_MODELS)}")
    return OWN_MODELS[model][1]


def load_own_spec(model: str) -> mujoco.MjSpec:
    """Parse one of our committed models into an editable MjSpec."""
    path = own_model_path(model)
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing; regenerate it with `python -m loco_mujoco.models.authoring`")
    return mujoco.MjSpec.from_file(str(path))


def main() -> None:
    parser = argparse.ArgumentParser(description="Regenerate our own MJCF models from the robot facts files.")
    parser.add_argument("models", nargs="*", default=list(OWN_MODELS), help=f"any of {', '.join(OWN_MODELS)}")
    args = parser.parse_args()
    for name in args.models:
        path = own_model_path(name)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(authored_xml(name))
        model = mujoco.MjModel.from_xml_path(str(path))
        print(f"wrote {path}: nq {model.nq}, nv {model.nv}, nu {model.nu}, mass {model.body_subtreemass[0]:.3f} kg")


if __name__ == "__main__":
    main()
