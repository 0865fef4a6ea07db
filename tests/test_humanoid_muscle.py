"""HumanoidMuscle: the composed myo-sim model (sizes, muscles, contacts, home pose) and the environment around it."""

import sys
import warnings

import mujoco
import numpy as np
import pytest

from loco_mujoco.datasets.sources.fetch import default_sources_root
from loco_mujoco.environments.humanoid_muscle import HumanoidMuscle
from loco_mujoco.models import myo_human

NQ, NV, NU = 35, 34, 80  # free root (7/6) + 7 anatomical and 7 knee-coupled joints per leg; 80 muscles


@pytest.fixture(scope="module")
def model():
    return myo_human.load_myo_human_spec().compile()


@pytest.fixture(scope="module")
def env():
    return HumanoidMuscle(task="walk", reward_type="none", seed=0)


def test_model_compiles_with_the_documented_sizes_and_joints(model):
    assert (model.nq, model.nv, model.nu, model.na, model.ntendon) == (NQ, NV, NU, NU, NU)
    free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    assert len(free) == 1 and model.body(int(model.jnt_bodyid[free[0]])).name == myo_human.ROOT_BODY
    names = {model.joint(j).name for j in range(model.njnt)} - {model.joint(free[0]).name}
    assert names == set(myo_human.LEG_JOINTS) | set(myo_human.COUPLED_JOINTS)
    assert model.neq == len(myo_human.COUPLED_JOINTS)  # each coupled joint follows its knee angle
    assert model.nsensor == 0
    assert 70.0 < model.body_subtreemass[0] < 80.0


def test_rigid_torso_and_pruning_keep_myo_sims_dynamics_and_muscle_paths(model):
    """The merged torso body, the deleted sites and the new scene leave mass matrix and muscle geometry unchanged."""
    import myo_sim

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # myo-sim's empty attach prefixes
        original = myo_sim.load_spec(myo_human.MYO_SIM_MODEL).compile()
    assert original.nq == model.nq and original.nu == model.nu
    mass_matrices, tendons = [], []
    for m in (original, model):
        d = mujoco.MjData(m)
        d.qpos[:] = model.key(myo_human.HOME_KEY).qpos
        d.qpos[model.joint("knee_angle_r").qposadr[0]] = 0.6  # not only the reference pose
        mujoco.mj_forward(m, d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        mass_matrices.append(full)
        tendons.append((d.ten_length.copy(), d.actuator_length.copy()))
    # our model is turned 90 deg about z to walk along +x: the joint block and the total mass are unchanged
    np.testing.assert_allclose(mass_matrices[1][6:, 6:], mass_matrices[0][6:, 6:], atol=1e-10)
    np.testing.assert_allclose(mass_matrices[1][:3, :3], mass_matrices[0][:3, :3], atol=1e-10)
    np.testing.assert_allclose(tendons[1][0], tendons[0][0], rtol=0, atol=1e-12)  # rounding of the turn only
    np.testing.assert_allclose(tendons[1][1], tendons[0][1], rtol=0, atol=1e-12)
    assert model.nbody < original.nbody and model.nsite < original.nsite


def test_all_actuators_are_muscles_exciting_in_zero_one(model):
    assert np.all(model.actuator_gaintype == mujoco.mjtGain.mjGAIN_MUSCLE)
    assert np.all(model.actuator_dyntype == mujoco.mjtDyn.mjDYN_MUSCLE)
    assert np.all(model.actuator_trntype == mujoco.mjtTrn.mjTRN_TENDON)
    assert np.all(model.actuator_ctrllimited)
    np.testing.assert_array_equal(model.actuator_ctrlrange, np.tile([0.0, 1.0], (NU, 1)))


def test_only_the_soles_touch_the_floor_and_legs_only_touch_through_pairs(model):
    collide = {model.geom(g).name for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]}
    soles = {model.geom(g).name for g in myo_human.sole_geoms(model)}
    assert collide == soles | {myo_human.FLOOR}
    feet = {model.body(b).id for b in myo_human.FOOT_BODIES}
    assert len(soles) >= 4 and all(model.geom_bodyid[model.geom(g).id] in feet for g in soles)
    # Sole geoms touch the floor but not each other by contype/conaffinity; explicit pairs keep legs apart.
    assert all(model.geom(g).conaffinity[0] == 0 for g in soles)
    assert model.npair > 0


def test_env_resets_and_steps_with_finite_observations(env):
    obs = env.reset()
    assert obs.shape == env.info.observation_space.shape == (NQ - 2 + NV,)
    assert env.info.action_space.shape == (NU,)
    assert np.all(np.isfinite(obs)) and not env.is_absorbing(obs)
    rng = np.random.default_rng(0)
    for _ in range(50):
        obs, _, absorbing, info = env.step(rng.uniform(-1.0, 1.0, NU))
        assert np.all(np.isfinite(obs)) and not info["physics_diverged"]
        if absorbing:
            obs = env.reset()


def test_default_integration_is_implicitfast_at_5_ms_with_the_coarse_step_settings(env, model):
    """The environment applies myo_human.apply_coarse_step_settings; myo_human's own model keeps myo-sim's values."""
    m = env.model
    assert m.opt.timestep == 0.005 and env._n_substeps == 2
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ISLAND
    assert np.all(m.actuator_actearly) and not np.any(model.actuator_actearly)
    for side in myo_human.SIDES:
        for joint, armature in myo_human.SLAVED_TRANSLATION_ARMATURE.items():
            assert m.dof_armature[m.joint(f"{joint}_{side}").dofadr[0]] == armature
            assert model.dof_armature[model.joint(f"{joint}_{side}").dofadr[0]] == 0.01  # myo-sim's
    coupled = [m.joint(j).id for j in myo_human.COUPLED_JOINTS]
    primary = [m.joint(j).id for j in myo_human.LEG_JOINTS]
    assert not np.any(m.jnt_limited[coupled]) and np.all(m.jnt_limited[primary])
    assert np.all(model.jnt_limited[[model.joint(j).id for j in myo_human.COUPLED_JOINTS]])
    # restore_myo_sim_settings (for fine-step references) gives myo-sim's numerical settings back
    restored = HumanoidMuscle(task="walk", reward_type="none").model
    myo_human.restore_myo_sim_settings(restored)
    np.testing.assert_array_equal(restored.dof_armature, model.dof_armature)
    np.testing.assert_array_equal(restored.jnt_limited, model.jnt_limited)
    assert not np.any(restored.actuator_actearly)
    assert not restored.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ISLAND


def test_random_excitation_does_not_diverge_at_the_default_timestep(env):
    rng = np.random.default_rng(1)
    env.reset()
    falls = 0
    for _ in range(400):
        _, _, absorbing, info = env.step(rng.uniform(-1.0, 1.0, NU))
        assert not info["physics_diverged"]
        if absorbing:
            falls += 1
            env.reset()
    assert falls > 0  # random excitation does not keep a human upright: resets were exercised


def _hinge_dofs(m):
    return np.array([m.jnt_dofadr[j] for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE])


def test_bang_bang_excitation_keeps_hinge_speeds_within_25_rad_s(env):
    """Every muscle fully relaxed or fully excited at random, a new draw each control step, a reset after each fall:
    no hinge joint moves faster than 25 rad/s in the states env.step returns. Explicit Euler at 5 ms reaches ~135 rad/s
    here (the muscles' force-velocity damping on the light foot), implicitfast without the coarse-step settings ~37.

    The same 10,000 control steps as ``bench/timestep_study.py --bang-bang`` (seed 0), which also prints the speeds
    inside the control steps; ~3 s.
    """
    hinges = _hinge_dofs(env.model)
    rng = np.random.default_rng(0)
    env.reset()
    worst, falls = 0.0, 0
    for _ in range(10_000):
        _, _, absorbing, info = env.step(rng.choice([-1.0, 1.0], NU))
        assert not info["physics_diverged"]
        worst = max(worst, float(np.abs(env.data.qvel[hinges]).max()))
        if absorbing:
            falls += 1
            env.reset()
    assert worst <= 25.0, f"largest hinge speed {worst:.1f} rad/s under bang-bang excitation"
    assert falls > 50  # many restarts from rest (all activations zero), where the excitation jumps are largest


def _floor_contacts(m, d, feet):
    """(foot body, penetration depth) of each contact between a foot geom and the floor."""
    floor = m.geom(myo_human.FLOOR).id
    out = []
    for k in range(d.ncon):
        g1, g2 = d.contact.geom1[k], d.contact.geom2[k]
        if floor in (g1, g2):
            body = int(m.geom_bodyid[g2 if g1 == floor else g1])
            if body in feet:
                out.append((body, -float(d.contact.dist[k])))
    return out


def test_floor_contact_stays_stable_in_quiet_stance(env):
    """From the home pose with 10 % co-contraction, over the first 0.2 s (before the body, which 10 % cannot hold,
    starts to sag): both feet keep touching the floor at every step and no sole sinks more than 5 mm into it."""
    m, d = env.model, env.data
    env.reset()
    for _ in range(20):
        _, _, absorbing, _ = env.step(np.full(NU, -0.8))
        assert not absorbing
        contacts = _floor_contacts(m, d, {m.body(b).id for b in myo_human.FOOT_BODIES})
        touching = {m.body(b).name[-1] for b, _ in contacts}
        assert touching == {"l", "r"}, f"feet on the floor: {sorted(touching)}"
        assert max(depth for _, depth in contacts) < 0.005


@pytest.mark.skipif(default_sources_root() is None, reason="needs ../shared/mocap or LOCO_MUJOCO_SOURCES")
def test_expert_states_are_reachable_and_followed_like_the_fine_step_reference(make_env):
    """Resetting onto the walking dataset's states reproduces them, and 0.1 s from each (10 % excitation) the default
    integration stays close to myo-sim's own model at 0.25 ms: on average within 0.03 rad and 4 mm (measured 0.016 rad
    and 0.9 mm; explicit Euler at 2.5 ms, the previous default: ~0.006 rad and 0.3 mm), never diverging or exceeding
    25 rad/s."""
    env = make_env("HumanoidMuscle.walk")
    states = env.create_dataset()["states"]
    reference = HumanoidMuscle(task="walk", reward_type="none", timestep=0.00025, n_substeps=40)
    myo_human.restore_myo_sim_settings(reference.model)
    hinges = _hinge_dofs(env.model)
    mask = env.get_kinematic_obs_mask()
    joint_err, height_err = [], []
    for frame in np.linspace(0, len(states) - 1, 12).astype(int):
        paths = []
        for e in (env, reference):
            obs = e.reset(states[frame])
            np.testing.assert_allclose(obs[mask], states[frame][mask])
            path = []
            for _ in range(10):
                _, _, _, info = e.step(np.full(NU, -0.8))
                assert not info["physics_diverged"]
                path.append(e.data.qpos.copy())
            paths.append(np.array(path))
        assert np.abs(env.data.qvel[hinges]).max() <= 25.0
        joint_err.append(np.sqrt(np.mean((paths[0][:, 7:] - paths[1][:, 7:]) ** 2)))
        height_err.append(np.sqrt(np.mean((paths[0][:, 2] - paths[1][:, 2]) ** 2)))
    assert np.mean(joint_err) < 0.03 and np.mean(height_err) < 0.004, (np.mean(joint_err), np.mean(height_err))


def test_actions_minus_one_and_plus_one_are_zero_and_full_excitation(env):
    env.reset()
    env.step(-np.ones(NU))
    np.testing.assert_array_equal(env.data.ctrl, 0.0)
    env.step(np.ones(NU))
    np.testing.assert_array_equal(env.data.ctrl, 1.0)
    env.step(np.zeros(NU))
    np.testing.assert_allclose(env.data.ctrl, 0.5)


def test_pd_control_is_rejected_naming_the_valid_choice():
    with pytest.raises(ValueError, match="invalid control for HumanoidMuscle 'pd'; valid: muscle"):
        HumanoidMuscle(task="walk", reward_type="none", control="pd")


def _lowest_point(m, d, g):
    """Lowest world z of a capsule, sphere or ellipsoid geom, from its pose and size alone."""
    z, rot, size = d.geom_xpos[g][2], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
    kind = m.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return z - abs(rot[2, 2]) * size[1] - size[0]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return z - size[0]
    assert kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID, f"unexpected sole geom type {kind}"
    return z - np.sqrt(np.sum((rot[2, :] * size) ** 2))


def test_home_pose_stands_with_the_soles_on_the_floor(env):
    env.reset()
    m, d = env.model, env.data
    for side in ("l", "r"):
        feet = {m.body(f"{b}_{side}").id for b in ("calcn", "toes")}
        lowest = min(_lowest_point(m, d, g) for g in myo_human.sole_geoms(m) if m.geom_bodyid[g] in feet)
        assert abs(lowest) < 0.01, f"{side} sole {lowest * 1e3:.1f} mm from the floor"
    lo, hi = env.ROOT_HEIGHT_RANGE
    assert lo < d.qpos[2] < hi and 0.9 < d.qpos[2] < 1.0
    # the knee couplings hold in the home pose: no equality constraint is violated
    mujoco.mj_forward(m, d)
    eq_rows = d.efc_type[: d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert eq_rows.sum() == m.neq and np.abs(d.efc_pos[: d.nefc][eq_rows]).max() < 1e-9


def test_leg_joint_table_names_joints_and_bodies_of_the_model(env):
    for side, leg in HumanoidMuscle.LEG_JOINTS.items():
        for role, name in leg.items():
            if role == "foot_body":
                assert env.model.body(name).name == name
            else:
                assert env.model.joint(name).name == name and name.endswith(f"_{side}")


def test_default_construction_falls_back_to_the_nominal_speed_without_a_dataset():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "no dataset to take the target speed from" until one exists
        env = HumanoidMuscle()
    assert env.task_name == "walk" and env.control == "muscle" and env.target_velocity > 0


def test_missing_myo_sim_is_reported_by_package_name(monkeypatch):
    monkeypatch.setitem(sys.modules, "myo_sim", None)  # makes `import myo_sim` fail
    with pytest.raises(ModuleNotFoundError, match="myo-sim"):
        myo_human.myo_sim_models_dir()


def test_reusing_the_implicit_factorisation_is_the_default_and_close_to_mj_step(env):
    """Physics step 2 reuses step 1's factorisation of M - h D (core/implicit_reuse.py). The same state and controls
    give a control step within a small distance of mj_step's, but not identical (the matrix is stale)."""
    assert env.reuse_implicit_factor and HumanoidMuscle.REUSE_IMPLICIT_FACTOR
    m, d = env.model, env.data
    rng = np.random.default_rng(0)
    env.reset()
    for _ in range(20):
        env.step(rng.uniform(-1, 1, m.nu))
    d.ctrl[:] = rng.uniform(0, 1, m.nu)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION  # state, controls and the solver's warm start
    start = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, start, spec)

    def control_step(reuse: bool) -> np.ndarray:
        mujoco.mj_setState(m, d, start, spec)
        env.reuse_implicit_factor = reuse
        try:
            env.step_physics()
        finally:
            env.reuse_implicit_factor = True
        return np.concatenate([d.qpos, d.qvel, d.act])

    exact, reused = control_step(False), control_step(True)
    assert not np.array_equal(exact, reused)
    assert np.abs(exact[:m.nq] - reused[:m.nq]).max() < 1e-3  # rad or m
    assert np.abs(exact[m.nq:m.nq + m.nv] - reused[m.nq:m.nq + m.nv]).max() < 0.2  # rad/s
    assert np.array_equal(control_step(True), reused)  # deterministic


def test_reusing_the_factorisation_needs_an_implicit_integrator():
    from loco_mujoco.core import implicit_reuse

    model = mujoco.MjModel.from_xml_string("<mujoco><option integrator='Euler'/><worldbody/></mujoco>")
    with pytest.raises(ValueError, match="needs integrator mjINT_IMPLICIT or mjINT_IMPLICITFAST"):
        implicit_reuse.check_supported(model)
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    implicit_reuse.check_supported(model)  # libmujoco exports what it needs
