import numpy as np
from mushroom_rl.core import Agent, Core
from mushroom_rl.policy import Policy

import loco_mujoco as lm


class UniformPolicy(Policy):
    def __init__(self, n_act, seed):
        super().__init__()
        self._n, self._rng = n_act, np.random.default_rng(seed)

    def draw_action(self, state):
        return self._rng.uniform(-1, 1, self._n)

    def reset(self):
        pass


def test_env_runs_in_the_mushroom_core_loop():
    env = lm.LocoEnv.make("UnitreeH1.walk", horizon=50)
    agent = Agent(env.info, UniformPolicy(env.info.action_space.shape[0], seed=0))
    dataset = Core(agent, env).evaluate(n_episodes=3, quiet=True)
    last = np.array([s[-1] for s in dataset])
    absorbing = np.array([s[-2] for s in dataset])
    assert last.sum() == 3 and last[-1]
    assert all(len(s[0]) == env.info.observation_space.shape[0] for s in dataset)
    assert absorbing.sum() <= 3 and (not absorbing.any() or last[absorbing].all())
    assert len(dataset) <= 150
