"""Building blocks shared by the baselines: networks, standardizer, policy, discriminators, expert data,
the fast TRPO learner, the adversarial-imitation loop, evaluation and logging."""

from baselines.common.adversarial import AdversarialConfig, AdversarialImitation
from baselines.common.discriminators import AdaptiveBeta, Discriminator, VariationalDiscriminator
from baselines.common.evaluation import evaluate
from baselines.common.expert_data import ExpertData, kinematic_obs_mask
from baselines.common.fast_trpo import FastTRPO
from baselines.common.logger import CSVLogger
from baselines.common.networks import MushroomMLP, build_mlp
from baselines.common.policy import GaussianPolicy
from baselines.common.standardizer import RunningStandardizer

__all__ = ["AdaptiveBeta", "AdversarialConfig", "AdversarialImitation", "CSVLogger", "Discriminator", "ExpertData",
           "FastTRPO", "GaussianPolicy", "MushroomMLP", "RunningStandardizer", "VariationalDiscriminator",
           "build_mlp", "evaluate", "kinematic_obs_mask"]
