"""Evaluation metrics: trajectory distances, contacts, gait metrics and state-distribution distances."""

import numpy as np
import pytest

from loco_mujoco.metrics import (
    classifier_auc,
    dtw_distance,
    euclidean_distance,
    foot_contacts,
    frechet_distance,
    gait_metrics,
    mmd_rbf,
    sliced_wasserstein,
    stance_sliding,
)

DISTRIBUTION_METRICS = (mmd_rbf, sliced_wasserstein, classifier_auc)


# ---------------------------------------------------------------- trajectory distances


@pytest.mark.parametrize("distance", [euclidean_distance, dtw_distance, frechet_distance])
def test_identical_trajectories_are_at_distance_zero(distance):
    a = np.random.default_rng(0).normal(size=(200, 7))
    assert distance(a, a.copy()) == 0.0


def test_dtw_ignores_a_phase_shift_that_euclidean_penalises():
    t = np.arange(300)
    a, b = np.sin(2 * np.pi * t / 100), np.sin(2 * np.pi * (t - 10) / 100)
    euclid = euclidean_distance(a, b)
    assert euclid == pytest.approx(np.mean(np.abs(a - b)))
    # Only the 10 unmatched steps at either end cost anything: RMS 0.093 vs a mean gap of 0.39.
    assert dtw_distance(a, b) < 0.25 * euclid
    assert frechet_distance(a, b) > euclid  # Fréchet is a worst case over the coupling, not a mean


def test_dtw_is_normalised_by_the_longer_length():
    a, b = np.zeros((100, 2)), np.ones((100, 2))  # every step 1 * sqrt(2) apart
    assert dtw_distance(a, b) == pytest.approx(np.sqrt(2))
    assert dtw_distance(np.zeros((50, 2)), np.ones((200, 2))) == pytest.approx(np.sqrt(2))


def test_frechet_hand_examples():
    # b's middle point is 3 from a[1], and further from a[0] and a[2]: every coupling pays at least 3,
    # and the diagonal coupling pays exactly 3 (1, 3, 1).
    a = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    b = np.array([[0.0, 1.0], [1.0, 3.0], [2.0, 1.0]])
    assert frechet_distance(a, b) == pytest.approx(3.0)
    # Reparametrisation is free: couple (0,0), (0,1), (1,2), (2,2), all at distance 0.
    assert frechet_distance([0.0, 2.0, 2.0], [0.0, 0.0, 2.0]) == 0.0
    assert euclidean_distance([0.0, 2.0, 2.0], [0.0, 0.0, 2.0]) == pytest.approx(2 / 3)


def test_frechet_respects_its_bounds():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(40, 3)), rng.normal(size=(55, 3))
    d = np.linalg.norm(a[:, None] - b[None], axis=2)
    f = frechet_distance(a, b)
    assert f >= max(d[0, 0], d[-1, -1])  # the end points are always coupled
    assert f >= max(d.min(axis=1).max(), d.min(axis=0).max())  # every point is coupled to some point
    c = b[:40]
    assert f <= d.max() and frechet_distance(a, c) <= np.linalg.norm(a - c, axis=1).max()  # diagonal coupling
    assert frechet_distance(a, b) == pytest.approx(frechet_distance(b, a))


@pytest.mark.parametrize("distance", [euclidean_distance, dtw_distance, frechet_distance])
def test_trajectory_shape_mismatch_raises(distance):
    with pytest.raises(ValueError, match="dimension"):
        distance(np.zeros((10, 3)), np.zeros((10, 4)))
    with pytest.raises(ValueError, match="empty"):
        distance(np.zeros((0, 3)), np.zeros((10, 3)))
    with pytest.raises(ValueError, match="shape"):
        distance(np.zeros((10, 3, 1)), np.zeros((10, 3)))


# ---------------------------------------------------------------- contacts and gait


def test_contacts_and_stance_sliding():
    h = np.array([[0.0, 0.05], [0.009, 0.01], [0.02, -0.001]])
    c = foot_contacts(h, 0.01)
    np.testing.assert_array_equal(c, [[True, False], [True, False], [False, True]])
    v = np.zeros((3, 2, 2))
    v[0, 0] = (3.0, 4.0)
    v[0, 1] = (9.0, 9.0)  # swing foot: ignored
    np.testing.assert_allclose(stance_sliding(v, c), [5.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="shape"):
        stance_sliding(v[:2], c)
    with pytest.raises(ValueError, match="sole_height"):
        foot_contacts(h[:, 0], 0.01)
    with pytest.raises(ValueError, match="contact_height"):
        foot_contacts(h, 0.0)


def synthetic_biped(speed=1.2, clearance=0.1, contact_height=0.02, frames=1000, period=100):
    """A biped at 100 Hz: 1 s strides, 60 % stance, feet half a cycle apart, planted feet never slide."""
    t = np.arange(frames)
    sole, feet_x = np.zeros((frames, 2)), np.zeros((frames, 2))
    stride = speed * period * 0.01
    for f, offset in enumerate((7, 57)):
        cycle, phase = np.divmod(t + offset, period)
        s = np.clip((phase - 0.6 * period) / (0.4 * period), 0.0, None)  # swing progress, 0 in stance
        swing = phase >= 0.6 * period
        # Swing starts above the contact band and peaks at `clearance` mid-swing (s = 0.5 is sampled).
        sole[:, f] = np.where(swing, 2 * contact_height + (clearance - 2 * contact_height) * np.sin(np.pi * s), 0.0)
        feet_x[:, f] = stride * (cycle + (1 - np.cos(np.pi * s)) / 2)  # eased swing: zero speed at touchdown
    foot_xy = np.stack([feet_x, np.broadcast_to([0.1, -0.1], (frames, 2))], axis=2)
    root_xy = np.column_stack([speed * t * 0.01, np.zeros(frames)])
    heading = np.broadcast_to([2.0, 0.0], (frames, 2))  # not unit length: normalised by gait_metrics
    return sole, foot_xy, root_xy, heading, 0.01, contact_height


def test_synthetic_biped_gait():
    m = gait_metrics(*synthetic_biped())
    assert m["forward_speed"] == pytest.approx(1.2)
    assert m["cadence"] == pytest.approx(120.0)
    assert m["stride_length"] == pytest.approx(1.2)  # speed x 1 s stride
    assert m["duty_factor"] == pytest.approx(0.6)
    assert m["double_support"] == pytest.approx(0.2)
    assert m["foot_clearance"] == pytest.approx(0.1)
    assert m["foot_sliding"] < 0.01
    assert m["symmetry"] == pytest.approx(0.0, abs=1e-9)


def test_gait_limp_is_asymmetric_and_short_episodes_give_nan():
    sole, foot_xy, root_xy, heading, dt, ch = synthetic_biped()
    sole[:, 1] = np.where(sole[:, 1] < 0.08, 0.0, sole[:, 1])  # right foot stays down longer
    assert gait_metrics(sole, foot_xy, root_xy, heading, dt, ch)["symmetry"] > 0.1
    m = gait_metrics(np.zeros((30, 2)), foot_xy[:30], root_xy[:30], heading[:30], dt, ch)  # standing, no step
    assert np.isnan(m["cadence"]) and np.isnan(m["stride_length"]) and np.isnan(m["foot_clearance"])
    assert m["duty_factor"] == 1.0 and m["double_support"] == 1.0
    one = gait_metrics(sole[:1], foot_xy[:1], root_xy[:1], heading[:1], dt, ch)
    assert np.isnan(one["forward_speed"]) and np.isnan(one["foot_sliding"])


def test_gait_shape_mismatch_raises():
    sole, foot_xy, root_xy, heading, dt, ch = synthetic_biped(frames=50)
    with pytest.raises(ValueError, match="foot_xy"):
        gait_metrics(sole, foot_xy[:, :1], root_xy, heading, dt, ch)
    with pytest.raises(ValueError, match="heading_xy"):
        gait_metrics(sole, foot_xy, root_xy, heading[:-1], dt, ch)
    with pytest.raises(ValueError, match="dt"):
        gait_metrics(sole, foot_xy, root_xy, heading, 0.0, ch)


# ---------------------------------------------------------------- state distributions


@pytest.fixture(scope="module")
def gaussians():
    rng = np.random.default_rng(0)
    return rng.normal(size=(600, 5)), rng.normal(size=(600, 5))


def test_identical_state_sets(gaussians):
    x, _ = gaussians
    assert mmd_rbf(x, x.copy()) == 0.0
    assert sliced_wasserstein(x, x.copy()) == pytest.approx(0.0, abs=1e-12)
    assert classifier_auc(x, x.copy()) == pytest.approx(0.5, abs=0.05)


@pytest.mark.parametrize("metric", DISTRIBUTION_METRICS)
def test_distribution_distance_grows_with_the_shift(gaussians, metric):
    x, y = gaussians
    values = [metric(x, y + [shift, 0, 0, 0, 0]) for shift in (0.0, 0.5, 2.0)]
    assert values[0] < values[1] < values[2], values


def test_auc_extremes(gaussians):
    x, y = gaussians
    assert abs(classifier_auc(x, y) - 0.5) < 0.1  # same distribution
    assert classifier_auc(x, y + 10.0) > 0.99


@pytest.mark.parametrize("metric", DISTRIBUTION_METRICS)
def test_distribution_metrics_are_seeded(gaussians, metric):
    x, y = gaussians
    kwargs = {"max_samples": 300}  # subsampling exercised too
    assert metric(x, y + 0.5, seed=1, **kwargs) == metric(x, y + 0.5, seed=1, **kwargs)


@pytest.mark.parametrize("metric", DISTRIBUTION_METRICS)
def test_distribution_nan_rows_dropped_and_bad_input_raises(gaussians, metric):
    x, y = gaussians
    dirty = x.copy()
    dirty[::50, 2] = np.nan
    assert metric(dirty, y) == metric(x[np.isfinite(dirty).all(axis=1)], y)
    with pytest.raises(ValueError, match="dimension"):
        metric(x, y[:, :4])
    with pytest.raises(ValueError, match="empty"):
        metric(np.full((5, 5), np.nan), y)


def test_mmd_bandwidth():
    x, y = np.zeros((10, 2)), np.ones((10, 2))
    # k(x, y) = exp(-2 / (2 * 1^2)); MMD^2 = 1 + 1 - 2 exp(-1)
    assert mmd_rbf(x, y, bandwidth=1.0) == pytest.approx(np.sqrt(2 - 2 * np.exp(-1)))
    with pytest.raises(ValueError, match="bandwidth"):
        mmd_rbf(x, y, bandwidth=-1.0)


def test_gait_deviation_is_zero_for_the_expert_and_counts_undefined_metrics_fully():
    from loco_mujoco.metrics import gait_deviation

    expert = {"cadence": 100.0, "stride_length": 1.0, "symmetry": 0.0, "double_support": float("nan")}
    assert gait_deviation(expert, expert) == 0.0
    # cadence 50% off, stride undefined (counts 1), symmetry 0.02 off a floor of 0.05 (0.4); NaN expert skipped
    agent = {"cadence": 150.0, "stride_length": float("nan"), "symmetry": 0.02, "double_support": 0.3}
    assert gait_deviation(agent, expert) == pytest.approx((0.5 + 1.0 + 0.4) / 3)
    assert gait_deviation({"cadence": 1000.0}, {"cadence": 100.0}) == 1.0  # capped
