"""BVH (CMU) and DeepMimic parsers on every shared file and on broken copies."""

import numpy as np
import pytest

from loco_mujoco.datasets.human_gait import gait_from_motion, mirror
from loco_mujoco.datasets.motion import MotionFormatError
from loco_mujoco.datasets.sources.bvh import load_bvh
from loco_mujoco.datasets.sources.deepmimic import load_deepmimic
from loco_mujoco.datasets.sources.fetch import default_sources_root

ROOT = default_sources_root()
pytestmark = pytest.mark.skipif(ROOT is None, reason="needs ../shared/mocap or LOCO_MUJOCO_SOURCES")
BVH = sorted(p.name for p in (ROOT / "cmu").glob("*.bvh")) if ROOT else []
DEEPMIMIC = sorted(p.name for p in (ROOT / "deepmimic").glob("humanoid3d_*.txt")) if ROOT else []


@pytest.mark.parametrize("name", BVH)
def test_bvh_clip_has_plausible_human_geometry(name):
    m = load_bvh(ROOT / "cmu" / name)
    assert m.frequency == pytest.approx(120.0, rel=1e-3) and m.n_frames > 100
    kp = m.keypoints
    thigh = np.linalg.norm(kp["LeftLeg"] - kp["LeftUpLeg"], axis=1)
    assert np.ptp(thigh) < 1e-9 and 0.3 < thigh[0] < 0.5  # a rigid segment of human length
    assert 0.75 < np.median(kp["Hips"][:, 2]) < 1.1  # pelvis height in metres, Z up
    assert np.min(kp["LeftToeBase"][:, 2]) < 0.08  # the feet reach the floor
    np.testing.assert_allclose(np.linalg.norm(m.root_quat, axis=1), 1.0)


@pytest.mark.parametrize("name", DEEPMIMIC)
def test_deepmimic_clip_has_plausible_human_geometry(name):
    m = load_deepmimic(ROOT / "deepmimic" / name)
    assert m.frequency in (pytest.approx(30.0, rel=0.01), pytest.approx(120.0, rel=0.01))
    assert 0.7 < np.median(m.root_pos[:, 2]) < 1.0
    assert {"right_hip_x", "right_knee", "left_ankle_z"} <= set(m.joint_names)
    assert np.min(m.keypoints["left_toe"][:, 2]) < 0.05


def test_gait_angles_have_anatomical_signs_and_mirror_swaps_sides():
    gait = gait_from_motion(load_bvh(ROOT / "cmu" / "07_02.bvh"))
    for side in "lr":
        a = gait.angles[side]
        assert np.degrees(a["knee_flexion"]).max() > 45  # walking bends the knee ...
        assert np.degrees(a["hip_flexion"]).max() > 20 and np.degrees(a["hip_flexion"]).min() < -5  # ... swings
    m = mirror(gait)
    np.testing.assert_array_equal(m.angles["l"]["knee_flexion"], gait.angles["r"]["knee_flexion"])
    np.testing.assert_array_equal(m.pelvis_yaw, -gait.pelvis_yaw)
    assert mirror(m).mirrored is False


def _broken(tmp_path, src, name, edit):
    text = src.read_text()
    path = tmp_path / name
    path.write_text(edit(text))
    return path


@pytest.mark.parametrize("edit, problem", [
    (lambda t: t[: len(t) // 2], "frames"),  # truncated mid-motion
    (lambda t: t.replace("MOTION", "MOTON"), "MOTION"),
    (lambda t: t.replace("HIERARCHY", "HIERARCH"), "HIERARCHY"),
    (lambda t: t.replace("Frame Time: .0083333", "Frame Time: x"), "Frame Time"),
    (lambda t: t.rstrip() + " 1.0\n", "values"),  # an extra value on the last frame
    (lambda t: t.rstrip()[:-7] + " abc\n", "non-numeric"),
])
def test_broken_bvh_raises_naming_file_and_problem(tmp_path, edit, problem):
    path = _broken(tmp_path, ROOT / "cmu" / "07_02.bvh", "broken.bvh", edit)
    with pytest.raises(MotionFormatError, match=problem) as err:
        load_bvh(path)
    assert "broken.bvh" in str(err.value)


@pytest.mark.parametrize("edit, problem", [
    (lambda t: t[: len(t) // 2], "JSON"),
    (lambda t: t.replace('"Frames"', '"Framez"'), "Frames"),
    (lambda t: t.replace("[\n[", "[\n[0.5, ", 1), "values"),  # one value too many in the first frame
    (lambda t: t.replace("0.8475320000", "NaN", 1), "NaN"),
])
def test_broken_deepmimic_raises_naming_file_and_problem(tmp_path, edit, problem):
    src = ROOT / "deepmimic" / "humanoid3d_walk.txt"
    path = _broken(tmp_path, src, "broken.txt", edit)
    with pytest.raises(MotionFormatError, match=problem) as err:
        load_deepmimic(path, ROOT / "deepmimic" / "humanoid3d.txt")
    assert "broken.txt" in str(err.value)
