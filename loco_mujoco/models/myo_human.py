"""The musculoskeletal human of ``HumanoidMuscle``: myo-sim's MyoLeg (80 muscles) on its rigid torso, on a floor.

The model comes from the ``myo-sim`` package (Apache-2.0): its composed ``myolegs`` model, i.e. the bilateral
MyoLeg (Rajagopal et al. 2016 lineage: 80 Hill-type muscles on 80 spatial tendons with wrapping surfaces) attached
to myo-sim's passive anatomical torso scaffold (pelvis/spine/thorax/head welded together, no arms) under one free
body. Everything here is edited through the MjSpec API: the myo-sim display scene is replaced by a plain floor, and
what locomotion does not use but would cost simulation time is removed (sensors, ~740 unused torso muscle sites,
self-contacts and all contacts except feet-floor). Muscle, tendon, joint and inertial parameters are untouched.
"""

from __future__ import annotations

import functools
import importlib
import importlib.resources
import math
import warnings
from collections.abc import Mapping
from pathlib import Path

import mujoco
import numpy as np

MYO_SIM_MODEL = "myolegs"  # myo-sim's registry name: passive torso scaffold + MyoLeg, with a free joint "root"
ROOT_BODY = "root"  # myo-sim's "Full Body": a world-aligned frame at the pelvis origin holding the free joint
HOME_KEY = "home"
FLOOR = "floor"

# The anatomical joints of each leg (OpenSim / Rajagopal names), hip to toes.
_PRIMARY = ("hip_flexion", "hip_adduction", "hip_rotation", "knee_angle", "ankle_angle", "subtalar_angle",
            "mtp_angle")
# Joints that myo-sim drives from knee_angle through polynomial joint-equality constraints (tibia translations and
# rotations of the knee's moving axis, and the patella); they are kept as in myo-sim.
_COUPLED = ("knee_angle_translation2", "knee_angle_translation1", "knee_angle_rotation2", "knee_angle_rotation3",
            "knee_angle_beta_translation2", "knee_angle_beta_translation1", "knee_angle_beta_rotation1")
SIDES = ("r", "l")
LEG_JOINTS: tuple[str, ...] = tuple(f"{j}_{s}" for s in SIDES for j in _PRIMARY)
COUPLED_JOINTS: tuple[str, ...] = tuple(f"{j}_{s}" for s in SIDES for j in _COUPLED)
# Bodies whose collision geoms form the soles; the only geoms that touch the floor.
FOOT_BODIES: tuple[str, ...] = tuple(f"{b}_{s}" for s in SIDES for b in ("calcn", "toes"))


def myo_sim_models_dir() -> Path:
    """Folder of myo-sim's model files; a clear error naming the package when it is not installed."""
    try:
        importlib.import_module("myo_sim")
    except ImportError as err:
        raise ModuleNotFoundError(
            "HumanoidMuscle needs the musculoskeletal models of the 'myo-sim' package (import name 'myo_sim'), "
            "which is not installed: pip install myo-sim") from err
    models = Path(str(importlib.resources.files("myo_sim") / "models"))
    if not (models / "leg" / "assets" / "myolegs_chain.xml").is_file():
        raise FileNotFoundError(f"the installed 'myo-sim' package has no MyoLeg model under {models}; "
                                "reinstall it: pip install --force-reinstall myo-sim")
    return models


def load_myo_human_spec() -> mujoco.MjSpec:
    """An editable MjSpec of the musculoskeletal human standing on a floor, with a ``home`` keyframe.

    Built once per process (myo-sim composes its model from XML fragments, ~0.7 s) and copied on each call.
    """
    return _composed_spec().copy()


@functools.lru_cache(maxsize=1)
def _composed_spec() -> mujoco.MjSpec:
    myo_sim_models_dir()
    import myo_sim

    previous_hook = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda _msg: None)  # myo-sim attaches with empty prefixes; MuJoCo warns about saving
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            spec = myo_sim.load_spec(MYO_SIM_MODEL)
    finally:
        mujoco.set_mju_user_warning(previous_hook)
    spec.modelname = "myo_human"
    _replace_scene(spec)
    for sensor in list(spec.sensors):  # foot touch sensors: unused, and computed every step
        spec.delete(sensor)
    for pair in list(spec.pairs):  # leg-against-leg bone contacts; see _keep_only_foot_floor_contacts
        spec.delete(pair)
    _keep_only_foot_floor_contacts(spec)
    root = spec.body("Full Body")
    root.name = ROOT_BODY
    frees = [j for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
    if len(frees) != 1 or frees[0].parent.name != ROOT_BODY:
        raise RuntimeError(f"myo-sim's '{MYO_SIM_MODEL}' changed: expected one free joint on its root body")
    model = spec.compile()
    _delete_unused_sites(spec, model)
    spec.add_key(name=HOME_KEY, qpos=standing_qpos(model).tolist())
    return spec


def _replace_scene(spec: mujoco.MjSpec) -> None:
    """Drop myo-sim's display scene (floor 0.4 m down, pedestal, backdrop mesh, logo, cameras); add floor and light."""
    for element in [*spec.worldbody.geoms, *spec.worldbody.cameras, *spec.worldbody.lights]:
        spec.delete(element)
    used_meshes = {g.meshname for g in spec.geoms}
    for mesh in [m for m in spec.meshes if m.name not in used_meshes]:
        spec.delete(mesh)
    used_materials = {g.material for g in spec.geoms}
    for material in [m for m in spec.materials if m.name not in used_materials]:
        spec.delete(material)
    used_textures = {t for m in spec.materials for t in m.textures}
    for texture in [t for t in spec.textures if t.name not in used_textures]:
        spec.delete(texture)
    spec.stat.extent = math.nan  # myo-sim's scene fixed these for its backdrop; let MuJoCo compute them
    spec.stat.center = [math.nan, 0.0, 0.0]

    spec.add_texture(name="floor_grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.32, 0.36, 0.40], rgb2=[0.22, 0.25, 0.28], width=256, height=256,
                     mark=mujoco.mjtMark.mjMARK_EDGE, markrgb=[0.6, 0.6, 0.6])
    spec.add_material(name="floor_grid", textures=["", "floor_grid"], texrepeat=[1, 1], texuniform=True,
                      reflectance=0.05)
    spec.worldbody.add_geom(name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="floor_grid",
                            contype=1, conaffinity=1, condim=3, group=1)
    spec.worldbody.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=[0, 0, 4],
                             dir=[0.2, 0.3, -1.0], diffuse=[0.7, 0.7, 0.7], specular=[0.2, 0.2, 0.2],
                             castshadow=True)
    spec.worldbody.add_light(name="spot", mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM, pos=[0, -3, 3],
                             dir=[0, 1, -1], diffuse=[0.4, 0.4, 0.4], castshadow=False)


def _keep_only_foot_floor_contacts(spec: mujoco.MjSpec) -> None:
    """Only the sole geoms (calcaneus and toes) touch the floor; nothing touches itself.

    myo-sim lets every bone's collision geom touch the floor and adds 26 leg-against-leg pairs. An episode ends when
    the pelvis drops below 0.6 m, before knees, hips or the torso reach the floor, and the legs-crossing pairs cost
    ~7 % of the step (5 of them go through the general convex solver); the collision geoms stay as
    non-colliding, massless display geoms (group 4).
    """
    feet = {id(g) for name in FOOT_BODIES for g in spec.body(name).geoms}
    for geom in spec.geoms:
        if geom.name == FLOOR or id(geom) in feet:
            continue
        geom.contype, geom.conaffinity = 0, 0
    for name in FOOT_BODIES:
        collides = [g for g in spec.body(name).geoms if g.contype or g.conaffinity]
        if not collides:
            raise RuntimeError(f"myo-sim's '{MYO_SIM_MODEL}' changed: foot body '{name}' has no collision geom")
        for geom in collides:  # touch the floor (its conaffinity is 1), not each other
            geom.contype, geom.conaffinity = 1, 0


def _delete_unused_sites(spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """Delete sites no tendon passes through or wraps by: the passive torso keeps ~740 sites of its removed muscles,
    and MuJoCo computes every site's pose at each step."""
    used = set()
    for w in range(model.nwrap):
        kind = model.wrap_type[w]
        if kind == mujoco.mjtWrap.mjWRAP_SITE:
            used.add(model.site(int(model.wrap_objid[w])).name)
        elif kind in (mujoco.mjtWrap.mjWRAP_SPHERE, mujoco.mjtWrap.mjWRAP_CYLINDER) and model.wrap_prm[w] >= 0:
            used.add(model.site(int(model.wrap_prm[w])).name)  # side site choosing the wrapping side
    for site in list(spec.sites):
        if site.name not in used:
            spec.delete(site)


def myo_sim_standing_posture() -> dict[str, float]:
    """Joint angles of myo-sim's ``standing`` posture of its legs model (ankles set so heel and forefoot are level)."""
    from myo_sim.build.keyframes import load_posture_table

    try:
        return dict(load_posture_table()["models"][MYO_SIM_MODEL]["standing"]["joints"])
    except KeyError as err:
        raise RuntimeError(f"myo-sim has no 'standing' posture for '{MYO_SIM_MODEL}' any more") from err


def standing_qpos(model: mujoco.MjModel, joints: Mapping[str, float] | None = None) -> np.ndarray:
    """The home pose: ``joints`` (default: myo-sim's standing posture; others 0) with the knee couplings satisfied,
    upright, the pelvis at the height where the lowest sole point touches z = 0."""
    joints = myo_sim_standing_posture() if joints is None else joints
    qpos = model.qpos0.copy()
    for name, value in joints.items():
        qpos[model.joint(name).qposadr[0]] = value
    qpos = _satisfy_joint_couplings(model, qpos)
    root = model.joint(0)
    if root.type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise ValueError("the model's first joint must be the free root joint")
    adr = int(root.qposadr[0])
    qpos[adr : adr + 7] = [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    qpos[adr + 2] -= lowest_sole_point(model, data)
    return qpos


def _satisfy_joint_couplings(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Set each joint-equality follower to the polynomial of its leader: q1 - q1_0 = sum_k c_k (q2 - q2_0)^k."""
    qpos = qpos.copy()
    for e in range(model.neq):
        if model.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT or model.eq_obj2id[e] < 0:
            continue
        a1 = model.jnt_qposadr[model.eq_obj1id[e]]
        a2 = model.jnt_qposadr[model.eq_obj2id[e]]
        x = qpos[a2] - model.qpos0[a2]
        qpos[a1] = model.qpos0[a1] + sum(c * x**k for k, c in enumerate(model.eq_data[e][:5]))
    return qpos


def sole_geoms(model: mujoco.MjModel) -> list[int]:
    """Ids of the collision geoms of the feet (the only ones that touch the floor)."""
    bodies = {model.body(name).id for name in FOOT_BODIES}
    return [g for g in range(model.ngeom)
            if model.geom_bodyid[g] in bodies and (model.geom_contype[g] or model.geom_conaffinity[g])]


def lowest_sole_point(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """Height (m) of the lowest point of the sole geoms in the current pose (needs ``mj_kinematics``)."""
    floor = model.geom(FLOOR).id
    fromto = np.zeros(6)
    lowest = math.inf
    for g in sole_geoms(model):
        distance = mujoco.mj_geomDistance(model, data, g, floor, 10.0, fromto)
        lowest = min(lowest, distance + float(model.geom_pos[floor][2]))
    return lowest
