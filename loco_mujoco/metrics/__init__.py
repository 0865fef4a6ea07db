"""Evaluation metrics for imitation learning of legged locomotion, in pure numpy/scipy/sklearn.

Trajectory distances between an agent and a reference trajectory (:mod:`.trajectory`: Euclidean, DTW,
Fréchet, in the inputs' unit), the project's single foot-contact definition (:mod:`.contacts`), gait metrics
of one episode (:mod:`.gait`: speed, cadence, stride, duty factor, support, clearance, sliding, symmetry) and
distances between sets of states (:mod:`.distribution`: RBF MMD, sliced Wasserstein, classifier AUC). This
package imports nothing else from loco_mujoco, nor mujoco or torch, so any layer of the project may use it.
"""

from loco_mujoco.metrics.contacts import foot_contacts, stance_sliding
from loco_mujoco.metrics.distribution import classifier_auc, mmd_rbf, sliced_wasserstein
from loco_mujoco.metrics.gait import gait_deviation, gait_metrics
from loco_mujoco.metrics.trajectory import dtw_distance, euclidean_distance, frechet_distance

__all__ = [
    "classifier_auc",
    "dtw_distance",
    "euclidean_distance",
    "foot_contacts",
    "frechet_distance",
    "gait_deviation",
    "gait_metrics",
    "mmd_rbf",
    "sliced_wasserstein",
    "stance_sliding",
]
