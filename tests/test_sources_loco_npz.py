"""Original LocoMuJoCo .npz layout: loading the shared mini datasets, round trips and broken archives."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from loco_mujoco.datasets.motion import MotionFormatError
from loco_mujoco.datasets.sources.fetch import SOURCE_FILES, default_sources_root
from loco_mujoco.datasets.sources.loco_npz import OLD_ROOT_OFFSET, load_loco_npz, save_loco_npz

ROOT = default_sources_root()
NPZ = sorted(r for r in SOURCE_FILES if r.startswith("loco-mujoco-format/") and r.endswith(".npz"))
ROBOT = {"UnitreeH1": "UnitreeH1", "TALOS": "Talos", "ATLAS": "Atlas", "UnitreeG1": "UnitreeG1",
         "humanoid": "HumanoidTorque", "walk_straight": "UnitreeA1"}


def shared(relpath):
    if ROOT is None:
        pytest.skip("shared motion sources not found (set LOCO_MUJOCO_SOURCES)")
    return ROOT / relpath


def _robot(relpath):
    return next(r for key, r in ROBOT.items() if key in relpath)


@pytest.mark.parametrize("relpath", NPZ)
def test_shared_npz(relpath):
    robot = _robot(relpath)
    family = "pelvis_opensim" if robot == "HumanoidTorque" else None
    m = load_loco_npz(shared(relpath), root_offset=OLD_ROOT_OFFSET[robot], root_family=family)
    assert m.frequency == pytest.approx(500.0) and m.n_frames == (1500 if robot == "UnitreeA1" else 500)
    assert m.skeleton == "loco-mujoco" and m.meta["format"] == "loco-mujoco-npz"
    assert np.allclose(np.linalg.norm(m.root_quat, axis=1), 1.0)
    assert m.joint_velocities.shape == m.joint_angles.shape and m.meta["root_velocity"].shape == (m.n_frames, 6)
    assert not any(n.startswith(("pelvis_", "trunk_")) for n in m.joint_names)
    height = m.root_pos[:, 2]
    low, high = {"UnitreeA1": (0.2, 0.35), "UnitreeG1": (0.65, 0.8)}.get(robot, (0.85, 1.1))
    assert low < height.min() and height.max() < high
    up = Rotation.from_quat(m.root_quat[:, [1, 2, 3, 0]]).apply([0, 0, 1])[:, 2]
    assert up.min() > 0.95  # upright trunk
    if robot == "UnitreeA1":
        assert list(m.meta["split_points"]) == [0, 500, 1000, 1500] and m.meta["dir_arrow"].shape == (1500, 9)
        assert m.angle("FR_calf_joint").max() < -1.0


def test_root_chains(tmp_path):
    n = 4
    arrays = {f"q_{j}": np.zeros(n) for j in ("pelvis_tx", "pelvis_tz", "pelvis_ty", "pelvis_tilt", "pelvis_list",
                                              "pelvis_rotation", "knee")}
    arrays.update(q_pelvis_tilt=np.full(n, 0.1), q_pelvis_tz=np.full(n, 0.3))
    arrays.update({f"d{k}": np.zeros(n) for k in list(arrays)})
    np.savez(tmp_path / "p.npz", **arrays)
    m = load_loco_npz(tmp_path / "p.npz", root_offset=(0, 0, 1))
    assert np.allclose(m.root_pos[0], [0, 0.3, 1]) and m.joint_names == ("knee",)
    assert np.allclose(Rotation.from_quat(m.root_quat[0, [1, 2, 3, 0]]).as_rotvec(), [0, -0.1, 0])
    trunk = {f"q_trunk_{j}": np.zeros(n) for j in ("tx", "ty", "tz", "rotation", "list", "tilt")}
    trunk.update(q_trunk_rotation=np.full(n, 0.3), q_trunk_tilt=np.full(n, 0.2), q_FR_hip_joint=np.zeros(n))
    trunk.update({f"d{k}": np.zeros(n) for k in list(trunk)})
    np.savez(tmp_path / "t.npz", **trunk)
    m = load_loco_npz(tmp_path / "t.npz")
    expected = Rotation.from_euler("ZY", [0.3, 0.2]).as_quat()  # intrinsic: Rz(rotation) then Ry(tilt)
    assert np.allclose(np.abs(m.root_quat[0] @ expected[[3, 0, 1, 2]]), 1.0)


@pytest.mark.parametrize("name", ["02-constspeed_UnitreeH1.npz", "02-constspeed_TALOS.npz", "walk_straight.npz"])
def test_round_trip(tmp_path, name):
    src = shared(f"loco-mujoco-format/{name}")
    offset = OLD_ROOT_OFFSET[_robot(name)]
    m = load_loco_npz(src, root_offset=offset)
    family = m.meta["root_family"]
    save_loco_npz(tmp_path / "a.npz", m, root_offset=offset, root_family=family)
    save_loco_npz(tmp_path / "b.npz", m, root_offset=offset, root_family=family)
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    with np.load(src) as orig, np.load(tmp_path / "a.npz") as again:
        assert orig.files == again.files
        for key in orig.files:
            assert orig[key].dtype == again[key].dtype and orig[key].shape == again[key].shape
            np.testing.assert_allclose(again[key], orig[key], rtol=0, atol=1e-12, err_msg=key)
    m2 = load_loco_npz(tmp_path / "a.npz", root_offset=offset)
    np.testing.assert_allclose(m2.root_quat, m.root_quat, atol=1e-12)
    assert m2.joint_names == m.joint_names


def test_save_needs_velocities(tmp_path):
    m = load_loco_npz(shared("loco-mujoco-format/02-constspeed_UnitreeH1.npz"))
    m.joint_velocities = None
    with pytest.raises(ValueError, match="joint_velocities"):
        save_loco_npz(tmp_path / "x.npz", m)


def _break(arrays, kind):
    if kind == "missing_dq":
        del arrays["dq_knee_angle_r"]
    elif kind == "unequal":
        arrays["q_knee_angle_l"] = arrays["q_knee_angle_l"][:-1]
    elif kind == "nan":
        arrays["q_hip_flexion_r"] = arrays["q_hip_flexion_r"].copy()
        arrays["q_hip_flexion_r"][17] = np.nan
    elif kind == "no_root":
        arrays = {k: v for k, v in arrays.items() if "pelvis" not in k}
    elif kind == "missing_root":
        del arrays["q_pelvis_list"], arrays["dq_pelvis_list"]
    return arrays


BROKEN = {"missing_dq": "missing dq_knee_angle_r", "unequal": "unequal array lengths", "nan": "q_hip_flexion_r",
          "no_root": "unknown root joints", "missing_root": "q_pelvis_list", "not_zip": "not a readable .npz"}


@pytest.mark.parametrize("kind", sorted(BROKEN))
def test_broken_npz(tmp_path, kind):
    path = tmp_path / "broken.npz"
    if kind == "not_zip":
        path.write_bytes(shared("loco-mujoco-format/02-constspeed_UnitreeH1.npz").read_bytes()[:5000])
    else:
        with np.load(shared("loco-mujoco-format/02-constspeed_UnitreeH1.npz")) as data:
            np.savez(path, **_break(dict(data), kind))
    with pytest.raises(MotionFormatError) as err:
        load_loco_npz(path)
    assert str(path) in str(err.value) and BROKEN[kind] in str(err.value)
