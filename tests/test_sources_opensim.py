"""OpenSim .mot/.sto/.trc parsing on the shared recordings and on deliberately broken copies."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from loco_mujoco.datasets.human_gait import SIDES, HumanGait, gait_from_motion, marker_joint_centres
from loco_mujoco.datasets.motion import MotionFormatError
from loco_mujoco.datasets.sources.fetch import SOURCE_FILES, default_sources_root
from loco_mujoco.datasets.sources.opensim import load_opensim, load_trc

ROOT = default_sources_root()
MOT = sorted(r for r in SOURCE_FILES if r.startswith("opensim/") and r.endswith(".mot"))
TRC = sorted(r for r in SOURCE_FILES if r.startswith("opensim/") and r.endswith(".trc"))


def shared(relpath):
    if ROOT is None:
        pytest.skip("shared motion sources not found (set LOCO_MUJOCO_SOURCES)")
    return ROOT / relpath


@pytest.mark.parametrize("relpath", MOT)
def test_mot_files(relpath):
    m = load_opensim(shared(relpath))
    running = "running" in relpath
    assert m.frequency == pytest.approx(60.0, abs=0.05)
    assert m.n_frames == (600 if running else 211)
    assert len(m.joint_names) == (31 if running else 17)  # 37 / 23 coordinates minus the six pelvis ones
    assert not any(n.startswith("pelvis") or n.endswith(("_tx", "_ty", "_tz")) for n in m.joint_names)
    assert len(m.keypoints) == (41 if running else 0)
    assert 0.8 < m.root_pos[:, 2].min() and m.root_pos[:, 2].max() < 1.1
    assert np.allclose(np.linalg.norm(m.root_quat, axis=1), 1.0)
    knee = np.degrees(m.angle("knee_angle_r"))
    assert m.meta["knee_flexion_sign"] == -1 and knee.min() < -60 and knee.max() < 10
    assert set(m.meta["pelvis"]) >= {"pelvis_tilt", "pelvis_list", "pelvis_rotation"}
    assert np.abs(m.meta["pelvis"]["pelvis_tilt"]).max() < 0.5  # radians
    if running:  # markers sit on the body: ASIS height near the pelvis height, metres
        assert np.abs(m.keypoints["R.ASIS"][:, 2] - m.root_pos[:, 2]).max() < 0.15


@pytest.mark.parametrize("relpath", TRC)
def test_trc_files(relpath):
    m = load_trc(shared(relpath))
    assert m.frequency == pytest.approx(60.0, abs=0.1)
    assert len(m.keypoints) == 41 and 70 <= m.n_frames <= 80
    assert m.meta["header_num_frames"] == 900  # the files are excerpts of a 900-frame trial
    assert 0.8 < m.root_pos[:, 2].min() and m.root_pos[:, 2].max() < 1.2
    heel = m.keypoints["R.Heel"][:, 2]
    assert heel.min() < 0.1 and heel.max() < 0.5
    assert np.all(m.keypoints["R.ASIS"][:, 1] < m.keypoints["L.ASIS"][:, 1])  # y is left


def _synthetic_mot(tmp_path, tilt=0.0, rotation=0.0, extra=""):
    cols = ["time", "pelvis_tilt", "pelvis_list", "pelvis_rotation", "pelvis_tx", "pelvis_ty", "pelvis_tz",
            "knee_angle_r"]
    rows = [[t, tilt, 0.0, rotation, 0.1 * t, 0.9, 0.2, 30.0] for t in (0.0, 0.1, 0.2)]
    text = "m\nversion=1\nnRows=3\nnColumns=8\ninDegrees=yes\n" + extra + "endheader\n" + "\t".join(cols) + "\n"
    path = tmp_path / "synthetic.mot"
    path.write_text(text + "".join("\t".join(f"{v:.6f}" for v in r) + "\n" for r in rows))
    return path


def test_pelvis_frame_conversion(tmp_path):
    m = load_opensim(_synthetic_mot(tmp_path, rotation=90.0))
    assert np.allclose(m.root_pos[0], [0.0, -0.2, 0.9])  # OpenSim z (right) becomes -y
    yaw = Rotation.from_quat(m.root_quat[:, [1, 2, 3, 0]]).as_matrix()
    assert np.allclose(yaw[0], Rotation.from_euler("z", 90, degrees=True).as_matrix(), atol=1e-9)
    m = load_opensim(_synthetic_mot(tmp_path, tilt=10.0))
    tilt = Rotation.from_quat(m.root_quat[0, [1, 2, 3, 0]]).as_rotvec()
    assert np.allclose(tilt, [0.0, -np.radians(10.0), 0.0])
    assert m.meta["knee_flexion_sign"] == 1 and m.angle("knee_angle_r")[0] == pytest.approx(np.radians(30))


def test_sto_path_columns(tmp_path):
    names = ["time"] + [f"/jointset/ground_pelvis/{c}/{kind}" for c in
                        ("pelvis_tilt", "pelvis_list", "pelvis_rotation", "pelvis_tx", "pelvis_ty", "pelvis_tz")
                        for kind in ("value", "speed")]
    names += ["/jointset/hip_r/hip_flexion_r/value", "/forceset/soleus_r/activation"]
    rows = "".join("\t".join([str(t)] + ["0.5"] * (len(names) - 1)) + "\n" for t in (0.0, 0.01, 0.02))
    path = tmp_path / "coordinates.sto"
    path.write_text("Coordinates\ninDegrees=no\nendheader\n" + "\t".join(names) + "\n" + rows)
    m = load_opensim(path)
    assert m.joint_names == ("hip_flexion_r",) and m.angle("hip_flexion_r")[0] == 0.5
    assert len(m.meta["skipped_columns"]) == 7 and m.meta["in_degrees"] is False


def _set_cell(line, index, value):
    cells = line.split("\t")
    cells[index] = value
    return "\t".join(cells)


def _edit_lines(lines, kind):
    data = [i for i, ln in enumerate(lines) if ln[:1] in " 0123456789" and ln.strip()]
    if kind == "truncated":
        lines[-1] = lines[-1][: len(lines[-1]) // 2]
    elif kind == "dropped_row":
        del lines[-1]
    elif kind == "garbage":
        lines[data[3]] = _set_cell(lines[data[3]], 2, "abc")
    elif kind == "columns":
        lines[data[5]] = lines[data[5]].rsplit("\t", 1)[0]
    elif kind == "nan":
        lines[data[7]] = _set_cell(lines[data[7]], 4, "nan")
    elif kind == "no_endheader":
        lines = [ln for ln in lines if ln.strip() != "endheader"]
    elif kind == "units":
        lines = [ln for ln in lines if "degrees" not in ln]
    return lines


BROKEN_MOT = {"truncated": "data row 211", "dropped_row": "truncated", "garbage": "non-numeric value 'abc'",
              "columns": "has 23 values, expected 24", "nan": "NaN", "no_endheader": "missing 'endheader'",
              "units": "unknown units"}


@pytest.mark.parametrize("kind", sorted(BROKEN_MOT))
def test_broken_mot(tmp_path, kind):
    lines = shared("opensim/subject01_walk1_ik.mot").read_text().splitlines()
    path = tmp_path / "broken.mot"
    path.write_text("\n".join(_edit_lines(lines, kind)) + "\n")
    with pytest.raises(MotionFormatError) as err:
        load_opensim(path)
    assert str(path) in str(err.value) and BROKEN_MOT[kind] in str(err.value)


def test_too_few_frames(tmp_path):
    path = _synthetic_mot(tmp_path)
    path.write_text("\n".join(path.read_text().splitlines()[:-2]).replace("nRows=3", "nRows=1") + "\n")
    with pytest.raises(MotionFormatError, match="too few frames"):
        load_opensim(path)


BROKEN_TRC = {"empty_cell": "missing marker value", "units": "unknown units", "garbage": "non-numeric",
              "truncated": "data row 73 has"}


@pytest.mark.parametrize("kind", sorted(BROKEN_TRC))
def test_broken_trc(tmp_path, kind):
    lines = shared("opensim/walk_free_01.trc").read_text().splitlines()
    if kind == "empty_cell":
        cells = lines[10].split("\t")
        lines[10] = "\t".join(cells[:5] + [""] + cells[6:])
    elif kind == "units":
        lines[2] = lines[2].replace("\tmm\t", "\tinch\t")
    elif kind == "garbage":
        lines[12] = _set_cell(lines[12], 7, "1.2.3")
    else:
        lines[-1] = lines[-1][: len(lines[-1]) // 2]
    path = tmp_path / "broken.trc"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MotionFormatError) as err:
        load_trc(path)
    assert str(path) in str(err.value) and BROKEN_TRC[kind] in str(err.value)


# --- .trc markers to anatomical gait (joint centres from markers, then the keypoint angle path) ---

@pytest.mark.parametrize("relpath", TRC)
def test_trc_gait_has_plausible_walking_angles(relpath):
    gait = gait_from_motion(load_trc(shared(relpath)), 100.0)
    assert isinstance(gait, HumanGait) and gait.duration == pytest.approx(1.2, abs=0.05)
    assert 0.9 < gait.leg_length < 1.1 and 0.9 < np.median(gait.pelvis_pos[:, 2]) < 1.05
    for side in SIDES:
        a = {k: np.degrees(v) for k, v in gait.angles[side].items()}
        assert -25 < a["hip_flexion"].min() < -10 and 15 < a["hip_flexion"].max() < 35
        assert -5 < a["knee_flexion"].min() < 8 and 55 < a["knee_flexion"].max() < 75
        assert np.abs(a["ankle_dorsiflexion"]).max() < 25 and np.ptp(a["ankle_dorsiflexion"]) > 15
        assert np.abs(a["hip_adduction"]).max() < 12
    # the legs alternate: one thigh swings forward while the other goes back
    assert np.corrcoef(gait.angles["l"]["hip_flexion"], gait.angles["r"]["hip_flexion"])[0, 1] < -0.7


def test_trc_gait_matches_ik_of_the_same_trial():
    """walk_free_01 (3.07-4.27 s of subject01_walk1.trc) overlaps the IK solution subject01_walk1_ik.mot (0.5-4 s)."""
    trc = load_trc(shared("opensim/walk_free_01.trc"))
    mot = load_opensim(shared("opensim/subject01_walk1_ik.mot"))
    g_trc, g_mot = gait_from_motion(trc, 100.0), gait_from_motion(mot, 100.0)
    t_trc = trc.time[0] + np.arange(g_trc.n_frames) / 100.0
    t_mot = mot.time[0] + np.arange(g_mot.n_frames) / 100.0
    t = t_trc[t_trc <= t_mot[-1]]
    assert len(t) > 80
    for side in SIDES:
        for angle, rms_max in (("hip_flexion", 6.0), ("knee_flexion", 5.0), ("ankle_dorsiflexion", 6.0)):
            a = np.degrees(np.interp(t, t_trc, g_trc.angles[side][angle]))
            b = np.degrees(np.interp(t, t_mot, g_mot.angles[side][angle]))
            assert np.sqrt(np.mean((a - b) ** 2)) < rms_max, (side, angle)
            assert np.corrcoef(a, b)[0, 1] > (0.7 if angle == "ankle_dorsiflexion" else 0.98), (side, angle)


def test_trc_joint_centres_are_anatomical():
    centres = marker_joint_centres(load_trc(shared("opensim/walk_free_02.trc")))
    hip_width = np.linalg.norm(centres["l_hip"] - centres["r_hip"], axis=1)
    assert 0.15 < hip_width.mean() < 0.22  # Harrington: 0.66 x inter-ASIS width + 15 mm
    for side in SIDES:
        thigh = np.linalg.norm(centres[f"{side}_knee"] - centres[f"{side}_hip"], axis=1)
        shank = np.linalg.norm(centres[f"{side}_ankle"] - centres[f"{side}_knee"], axis=1)
        assert 0.38 < thigh.mean() < 0.52 and np.ptp(thigh) < 0.04  # a rigid segment despite skin motion
        assert 0.38 < shank.mean() < 0.52 and np.ptp(shank) < 0.04
        assert 0.05 < np.quantile(centres[f"{side}_ankle"][:, 2], 0.1) < 0.1


def test_trc_missing_marker_names_marker_and_file(tmp_path):
    lines = shared("opensim/walk_free_01.trc").read_text().splitlines()
    lines[3] = lines[3].replace("R.Shank.Front", "R.Shank.Front2")
    path = tmp_path / "no_shank_front.trc"
    path.write_text("\n".join(lines) + "\n")
    motion = load_trc(path)  # the file itself is well formed
    with pytest.raises(MotionFormatError) as err:
        gait_from_motion(motion)
    assert str(path) in str(err.value) and "'R.Shank.Front'" in str(err.value)


def test_trc_without_knee_motion_cannot_locate_the_knee():
    motion = load_trc(shared("opensim/walk_free_01.trc"))
    frozen = {k: np.repeat(v[:1], motion.n_frames, axis=0) for k, v in motion.keypoints.items()}
    still = replace(motion, keypoints=frozen)  # a static trial
    with pytest.raises(MotionFormatError, match="right knee: too little knee motion"):
        gait_from_motion(still)
