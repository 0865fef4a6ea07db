"""OpenSim .mot/.sto/.trc parsing on the shared recordings and on deliberately broken copies."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

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
