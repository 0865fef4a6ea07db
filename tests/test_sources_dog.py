"""Dog keypoint files and their A1 retargets (AMP JSON): shared files and broken copies."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from loco_mujoco.datasets.motion import MotionFormatError
from loco_mujoco.datasets.sources.dog import A1_JOINTS, KEYPOINT_NAMES, load_a1_json, load_dog_keypoints
from loco_mujoco.datasets.sources.fetch import SOURCE_FILES, default_sources_root

ROOT = default_sources_root()
DOG = sorted(r for r in SOURCE_FILES if r.startswith("noncommercial/dog-keypoints/") and r.endswith("_pos.txt"))
A1 = sorted(r for r in SOURCE_FILES if r.startswith("noncommercial/a1-retargeted/") and "LICENSE" not in r)
TOES = ("left_front_toe", "right_front_toe", "left_hind_toe", "right_hind_toe")


def shared(relpath):
    if ROOT is None:
        pytest.skip("shared motion sources not found (set LOCO_MUJOCO_SOURCES)")
    return ROOT / relpath


def test_keypoint_names():
    assert len(KEYPOINT_NAMES) == 27 and KEYPOINT_NAMES[0] == "pelvis" and KEYPOINT_NAMES[23] == "right_hind_toe"
    assert KEYPOINT_NAMES[1] == "kp1"


@pytest.mark.parametrize("relpath", DOG)
def test_dog_keypoints(relpath):
    m = load_dog_keypoints(shared(relpath))
    assert m.frequency == pytest.approx(60.0) and len(m.keypoints) == 27 and m.skeleton == "dog-keypoints"
    assert np.allclose(m.root_pos, m.keypoints["pelvis"])
    assert np.allclose(np.linalg.norm(m.root_quat, axis=1), 1.0)
    assert 0.05 < m.root_pos[:, 2].min() and m.root_pos[:, 2].max() < 0.6  # Z-up, metres
    assert min(m.keypoints[t][:, 2].min() for t in TOES) > -0.05
    start = (m.meta.get("clip_info") or {}).get("trim_start_frame") or 0
    assert m.root_pos[start:, 2].max() > 0.4  # standing dog after the trim start
    rot = Rotation.from_quat(m.root_quat[:, [1, 2, 3, 0]])
    left = rot.apply([0, 1, 0])
    side = m.keypoints["left_hip"] - m.keypoints["right_hip"]
    assert np.median(np.sum(left * side, axis=1)) > 0  # y axis points to the dog's left
    if "turn" not in relpath:  # the trunk x axis follows the direction of travel
        vel = np.gradient(m.root_pos[start:, :2], axis=0) * 60
        fwd, speed = rot.apply([1, 0, 0])[start:, :2], np.linalg.norm(vel, axis=1)
        moving = speed > 0.3
        cos = np.sum(fwd[moving] * vel[moving], axis=1) / (np.linalg.norm(fwd[moving], axis=1) * speed[moving])
        assert np.median(cos) > 0.9


@pytest.mark.parametrize("relpath", A1)
def test_a1_json(relpath):
    m = load_a1_json(shared(relpath))
    assert m.joint_names == A1_JOINTS and m.skeleton == "a1"
    assert m.frequency == pytest.approx(1 / 0.01677)
    assert 0.2 < m.root_pos[:, 2].min() and m.root_pos[:, 2].max() < 0.4
    assert np.allclose(np.linalg.norm(m.root_quat, axis=1), 1.0)
    calf = m.joint_angles[:, 2::3]
    assert calf.max() < -0.5 and calf.min() > -2.9  # Menagerie knee range is [-2.70, -0.92]
    finite_diff = np.diff(m.joint_angles, axis=0) / m.meta["frame_duration"]
    np.testing.assert_allclose(m.joint_velocities[:-1], finite_diff, atol=5e-3)  # verifies the column layout
    assert m.meta["toe_pos_local_raw"].shape == (m.n_frames, 12) and not m.keypoints


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


BROKEN_DOG = {"columns": "row 5 has 80 values, expected 81", "garbage": "non-numeric value 'x1'",
              "nan": "NaN", "one_frame": "too few frames"}


@pytest.mark.parametrize("kind", sorted(BROKEN_DOG))
def test_broken_dog(tmp_path, kind):
    lines = shared("noncommercial/dog-keypoints/dog_trot_joint_pos.txt").read_text().splitlines()
    if kind == "columns":
        lines[4] = lines[4].rsplit(",", 1)[0]
    elif kind == "garbage":
        cells = lines[7].split(",")
        lines[7] = ",".join(cells[:5] + ["\tx1"] + cells[6:])
    elif kind == "nan":
        lines[9] = "nan," + lines[9].split(",", 1)[1]
    else:
        lines = lines[:1]
    path = _write(tmp_path, "dog_broken_joint_pos.txt", "\n".join(lines) + "\n")
    with pytest.raises(MotionFormatError) as err:
        load_dog_keypoints(path)
    assert str(path) in str(err.value) and BROKEN_DOG[kind] in str(err.value)


BROKEN_A1 = {"short_frame": "frame 3 has 60 values, expected 61", "no_frames": "missing 'Frames'",
             "string": "non-numeric value 'a' in frame 2", "nan": "NaN", "truncated": "not a readable JSON",
             "duration": "FrameDuration"}


@pytest.mark.parametrize("kind", sorted(BROKEN_A1))
def test_broken_a1(tmp_path, kind):
    text = shared("noncommercial/a1-retargeted/trot0.txt").read_text()
    doc = json.loads(text)
    if kind == "short_frame":
        doc["Frames"][2] = doc["Frames"][2][:60]
    elif kind == "no_frames":
        del doc["Frames"]
    elif kind == "string":
        doc["Frames"][1][10] = "a"
    elif kind == "nan":
        doc["Frames"][4][8] = float("nan")
    elif kind == "duration":
        doc["FrameDuration"] = 0
    body = text[: len(text) // 2] if kind == "truncated" else json.dumps(doc)
    path = _write(tmp_path, "broken.txt", body)
    with pytest.raises(MotionFormatError) as err:
        load_a1_json(path)
    assert str(path) in str(err.value) and BROKEN_A1[kind] in str(err.value)
