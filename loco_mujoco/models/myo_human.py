"""The musculoskeletal human of ``HumanoidMuscle``: myo-sim's MyoLeg (80 muscles) on its rigid torso, on a floor.

The model comes from the ``myo-sim`` package (Apache-2.0): its composed ``myolegs`` model, i.e. the bilateral
MyoLeg (Rajagopal et al. 2016 lineage: 80 Hill-type muscles on 80 spatial tendons with wrapping surfaces) attached
to myo-sim's passive anatomical torso scaffold (pelvis/spine/thorax/head welded together, no arms) under one free
body. Everything here is edited through the MjSpec API: the myo-sim display scene is replaced by a plain floor, and
what locomotion does not use but would cost simulation time is removed (sensors, ~740 unused torso muscle sites,
bone-floor contacts other than the soles'). The passive torso's 15 welded bodies become one rigid body with the
same mass properties. Muscle, tendon, joint and inertial parameters are untouched.
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

from loco_mujoco.models.posture import apply_joint_couplings, lowest_point
from loco_mujoco.rotations import mat_to_quat, quat_conj, quat_mul, rotate

MYO_SIM_MODEL = "myolegs"  # myo-sim's registry name: passive torso scaffold + MyoLeg, with a free joint "root"
ROOT_BODY = "root"  # myo-sim's "Full Body": a world-aligned frame at the pelvis origin holding the free joint
TORSO_BODY = "torso"  # the rigid upper body (sacrum, lumbar spine, thorax, neck, head; no arms), fixed to the pelvis
_MYO_ROOT_BODY = "Full Body"
_SCAFFOLD_TOP = "sacrum"  # top body of myo-sim's passive torso scaffold: 15 bodies welded to the root
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
# Armature (kg, at adult size) that :func:`apply_coarse_step_settings` gives the knee's slaved translations: the
# tibia's translations relative to the femur and the patella's. Each moves at most 7 mm (tibia) or 5 cm (patella) per
# radian of knee flexion, so this adds at most 30 * 4.5e-5 + 1 * 4.6e-3 = 0.006 kg m^2 (~1 %) to the knee's inertia.
SLAVED_TRANSLATION_ARMATURE = {"knee_angle_translation1": 30.0, "knee_angle_translation2": 30.0,
                               "knee_angle_beta_translation1": 1.0, "knee_angle_beta_translation2": 1.0}


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

    Built once per process (~1 s, mostly myo-sim composing its model from XML fragments) and copied on each call.
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
    frees = [j for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
    if len(frees) != 1 or frees[0].parent.name != _MYO_ROOT_BODY:
        raise RuntimeError(f"myo-sim's '{MYO_SIM_MODEL}' changed: expected one free joint on '{_MYO_ROOT_BODY}'")
    with warnings.catch_warnings():  # compiling the composed spec repeats MuJoCo's empty-prefix warning
        warnings.simplefilter("ignore", UserWarning)
        _merge_torso_scaffold(spec, spec.compile())
        spec.body(_MYO_ROOT_BODY).name = ROOT_BODY
        # myo-sim's legs face -y; every other model here walks along +x: turn the body 90 deg about z under the
        # world-aligned root, so the free joint's quaternion stays identity when standing.
        legs = spec.body(ROOT_BODY).first_body()
        legs.quat = quat_mul(np.array([math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)]),
                              np.asarray(legs.quat, dtype=float))
        _keep_only_foot_floor_contacts(spec)
        model = spec.compile()
        _delete_unused_sites(spec, model)
        pruned = spec.compile()
    # Deleting a site a tendon uses can make MuJoCo drop that tendon and its muscle: make sure none went.
    if (pruned.ntendon, pruned.nu, pruned.nwrap) != (model.ntendon, model.nu, model.nwrap):
        raise RuntimeError("deleting unused sites removed tendons or muscles")
    spec.add_key(name=HOME_KEY, qpos=standing_qpos(pruned).tolist())
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

    spec.add_texture(name="floor_grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.32, 0.36, 0.40], rgb2=[0.22, 0.25, 0.28],
                     width=256, height=256, mark=mujoco.mjtMark.mjMARK_EDGE, markrgb=[0.6, 0.6, 0.6])
    material = spec.add_material(name="floor_grid", texrepeat=[1, 1], texuniform=True, reflectance=0.05)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor_grid"  # assigning a short list corrupts memory
    spec.worldbody.add_geom(name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="floor_grid",
                            contype=1, conaffinity=1, condim=3, group=1)
    spec.worldbody.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=[0, 0, 4],
                             dir=[0.2, 0.3, -1.0], diffuse=[0.5, 0.5, 0.5], specular=[0.2, 0.2, 0.2],
                             castshadow=False)
    spec.worldbody.add_light(name="spot", mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM, pos=[0, -2, 4],
                             dir=[0, 0.5, -1], diffuse=[0.5, 0.5, 0.5], cutoff=60, castshadow=True)


def _merge_torso_scaffold(spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """Replace myo-sim's passive torso scaffold by one rigid body with its mass, centre of mass, inertia and meshes.

    The scaffold's 15 bodies have no joints, so one body with their combined inertia moves identically; it also drops
    the ~700 sites of the torso muscles myo-sim removed (deleting them one by one takes MuJoCo seconds), the torso's
    unused wrapping surfaces and its collision geoms.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    root, top, pelvis = (model.body(n).id for n in (_MYO_ROOT_BODY, _SCAFFOLD_TOP, "pelvis"))
    scaffold = [b for b in range(model.nbody) if _is_in_subtree(model, b, top)]
    origin, to_root = data.xpos[root].copy(), data.xmat[root].reshape(3, 3).T  # world -> root frame

    masses = model.body_mass[scaffold]
    coms = (data.xipos[scaffold] - origin) @ to_root.T
    mass = float(masses.sum())
    com = masses @ coms / mass
    inertia = np.zeros((3, 3))
    for b, m, c in zip(scaffold, masses, coms, strict=True):
        rot = to_root @ data.ximat[b].reshape(3, 3)
        r = c - com
        inertia += rot @ np.diag(model.body_inertia[b]) @ rot.T + m * (r @ r * np.eye(3) - np.outer(r, r))

    meshes = []  # (mesh, material, rgba, group, pos, quat) of the bone meshes, in the root frame, as authored
    for g in range(model.ngeom):
        if (model.geom_bodyid[g] not in scaffold or model.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH
                or model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        mesh = int(model.geom_dataid[g])
        quat = mat_to_quat(to_root @ data.geom_xmat[g].reshape(3, 3))
        # The compiler re-centres a mesh on its inertia frame and moves the geom by (mesh_pos, mesh_quat): undo it.
        authored_quat = quat_mul(quat, quat_conj(model.mesh_quat[mesh]))
        offset = rotate(authored_quat, model.mesh_pos[mesh])
        material = model.material(int(model.geom_matid[g])).name if model.geom_matid[g] >= 0 else ""
        meshes.append((model.mesh(mesh).name, material, model.geom_rgba[g].copy(), int(model.geom_group[g]),
                       (data.geom_xpos[g] - origin) @ to_root.T - offset, authored_quat))

    spec.delete(spec.body(_SCAFFOLD_TOP))  # with its whole subtree
    # The new body sits at the root frame; express that frame in the pelvis (myo-sim's pelvis uses OpenSim's axes).
    to_pelvis = data.xmat[pelvis].reshape(3, 3).T @ data.xmat[root].reshape(3, 3)
    torso = spec.body("pelvis").add_body(
        name=TORSO_BODY, pos=data.xmat[pelvis].reshape(3, 3).T @ (origin - data.xpos[pelvis]),
        quat=mat_to_quat(to_pelvis))
    torso.explicitinertial = True
    torso.mass = mass
    torso.ipos = com
    torso.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    for mesh, material, rgba, group, pos, quat in meshes:
        torso.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh, material=material, rgba=rgba, group=group,
                       pos=pos, quat=quat, contype=0, conaffinity=0, mass=0.0)


def _is_in_subtree(model: mujoco.MjModel, body: int, top: int) -> bool:
    while body > 0:
        if body == top:
            return True
        body = int(model.body_parentid[body])
    return False


def _keep_only_foot_floor_contacts(spec: mujoco.MjSpec) -> None:
    """Only the sole geoms (calcaneus and toes) touch the floor; the legs touch each other only through myo-sim's
    explicit pairs.

    myo-sim lets every bone's collision geom (pelvis, femurs, tibias, thorax, head) touch the floor. An episode ends
    when the pelvis drops below 0.6 m, before knees, hips or the torso reach the floor, so only the soles need to.
    myo-sim's 26 leg-against-leg pairs (femur, tibia and foot geoms, frictionless) stay: they keep the legs from
    passing through each other for ~2 % of the step time. Explicit pairs ignore contype/conaffinity, so the bone
    geoms can be switched off here; they remain as massless display geoms (group 4).
    """
    for body in spec.bodies:
        if body.name == "world":  # its only collision geom is the floor
            continue
        is_foot = body.name in FOOT_BODIES
        collides = [g for g in body.geoms if g.contype or g.conaffinity]
        if is_foot and not collides:
            raise RuntimeError(f"myo-sim's '{MYO_SIM_MODEL}' changed: foot body '{body.name}' has no collision geom")
        for geom in collides:  # feet touch the floor (conaffinity 1) but not each other; the rest touches nothing
            geom.contype, geom.conaffinity = (1, 0) if is_foot else (0, 0)


def _delete_unused_sites(spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """Delete the sites no tendon passes through or wraps by (markers, touch-sensor and attachment sites): MuJoCo
    computes every site's pose at each step. Deleting one costs MuJoCo milliseconds, hence the torso merge first."""
    used = set()
    for w in range(model.nwrap):
        kind = int(model.wrap_type[w])
        if kind == mujoco.mjtWrap.mjWRAP_SITE:
            used.add(model.site(int(model.wrap_objid[w])).name)
        elif kind in (mujoco.mjtWrap.mjWRAP_SPHERE, mujoco.mjtWrap.mjWRAP_CYLINDER) and model.wrap_prm[w] >= 0:
            used.add(model.site(int(model.wrap_prm[w])).name)  # side site choosing the wrapping side
    if "" in used:
        raise RuntimeError("a tendon passes through an unnamed site; cannot tell the sites apart by name")
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
    qpos = apply_joint_couplings(model, qpos)
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


def sole_geoms(model: mujoco.MjModel) -> list[int]:
    """Ids of the collision geoms of the feet (the only ones that touch the floor)."""
    bodies = {model.body(name).id for name in FOOT_BODIES}
    return [g for g in range(model.ngeom)
            if model.geom_bodyid[g] in bodies and (model.geom_contype[g] or model.geom_conaffinity[g])]


def lowest_sole_point(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """Height (m) of the lowest point of the sole geoms in the current pose (needs ``mj_kinematics``)."""
    return lowest_point(model, data, sole_geoms(model), FLOOR)


def apply_coarse_step_settings(spec: mujoco.MjSpec) -> None:
    """Numerical settings that keep implicitfast at 5 ms stable and close to a fine-step reference.

    At 5 ms only an implicit integrator survives the muscles' force-velocity damping (the ankle's eigenvalue reaches
    -1000..-2000 /s at full excitation; explicit Euler needs dt < 2 ms there). implicitfast integrates that damping
    implicitly but passes the constraint forces, solved against the plain mass matrix, through M - dt*D. On the
    equality-slaved knee translations (a 28 g patella pulled by the quadriceps: dt*D/M ~ 150) that inconsistency
    made the model sag 73 mm off the reference within 1 s (bench/timestep_study.py). This function:

    - gives the slaved translations an armature (:data:`SLAVED_TRANSLATION_ARMATURE`, scaled with the body's mass
      for the smaller body sizes), so dt*D/M stays ~1-6 there; it adds ~1 % to the knee's inertia;
    - sets ``actearly`` on the muscles: the force uses the activation at the end of the step. Without it an
      excitation switched on at 5 ms reaches full activation within one step while the force still lags by one,
      and the ankle whips to 30-40 rad/s where the 0.25 ms reference stays under 6;
    - unlimits the slaved joints: their ranges are the images of the knee's range, so the knee's own limit already
      bounds them; as separate rows they only fought the couplings (and cost solver time);
    - disables constraint-island discovery: the whole body is one island anyway;
    - limits muscle activation to [0, 1]: MuJoCo integrates activation with explicit Euler, and at a user-chosen
      10 ms step (time constant 5 ms from rest) a full excitation overshot to activation 2, doubling the force
      for a step (bang-bang ankle speed 283 rad/s, 45 with the limit); at 5 ms activation never leaves [0, 1]
      and the limit changes nothing (3,000 bang-bang steps bit-identical).

    Muscle, tendon, inertial and contact parameters stay myo-sim's; only these numerical settings change.
    """
    size = spec.body("tibia_r").mass / _composed_spec().body("tibia_r").mass  # 1 at adult size, f**3 when scaled
    for side in SIDES:
        for joint, armature in SLAVED_TRANSLATION_ARMATURE.items():
            spec.joint(f"{joint}_{side}").armature = armature * size
    for joint in COUPLED_JOINTS:
        spec.joint(joint).limited = mujoco.mjtLimited.mjLIMITED_FALSE
    for actuator in spec.actuators:
        actuator.actearly = True
        actuator.actlimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.actrange = [0.0, 1.0]
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND


def restore_myo_sim_settings(model: mujoco.MjModel) -> None:
    """Undo :func:`apply_coarse_step_settings` on a compiled model: myo-sim's armature and limits on the slaved knee
    joints, no ``actearly``, island discovery on. For reference simulations at fine timesteps, where myo-sim's own
    settings are the model to compare with."""
    authored = _composed_spec()
    size = model.body("tibia_r").mass[0] / authored.body("tibia_r").mass  # f**3 of a scaled body; armature goes f**5
    for side in SIDES:
        for joint in SLAVED_TRANSLATION_ARMATURE:
            armature = authored.joint(f"{joint}_{side}").armature * size ** (5 / 3)
            model.dof_armature[model.joint(f"{joint}_{side}").dofadr[0]] = armature
    for joint in COUPLED_JOINTS:
        model.jnt_limited[model.joint(joint).id] = authored.joint(joint).limited != mujoco.mjtLimited.mjLIMITED_FALSE
    model.actuator_actearly[:] = False
    model.actuator_actlimited[:] = [a.actlimited == mujoco.mjtLimited.mjLIMITED_TRUE for a in authored.actuators]
    model.actuator_actrange[:] = [a.actrange for a in authored.actuators]
    model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_ISLAND)
