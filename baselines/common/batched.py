"""Batched on-policy collection: N environments per process, one policy forward pass per control step.

:class:`BatchedCollector` plays the part of ``mushroom_rl.core.Core.learn`` for the on-policy (adversarial)
agents, with ``N`` :class:`~loco_mujoco.LocoEnv` instances of the same task and settings instead of one:

* **one batched forward pass** per control step: ``policy.draw_actions(states)`` maps the ``(N, obs_dim)``
  states to ``(N, act_dim)`` actions (mean network in numpy, noise from the policy's own generator);
* **the environments step in threads**: each env's ``apply_action``, ``step_physics`` and ``finish_step``
  (``LocoEnv.step`` in three parts) run in a small pool, the envs split into contiguous chunks, one per
  thread, the caller's thread taking the first chunk. ``mj_step`` releases the GIL, so the physics of the
  chunks runs in parallel; the Python around it (~10 us per env step on UnitreeH1) interleaves. With
  ``n_threads=1`` the loop is plain sequential;
* **episodes per env, as Core has them**: an env whose transition is ``last`` (absorbing, or its episode
  reached the horizon) is reset at once, its next state is the reset observation; every env is reset at the
  start of each ``learn`` call (Core resets at the start of ``learn`` too), so the state carried from one
  ``learn`` call to the next is the generators only;
* **the batch handed to the fit** (``agent.fit_arrays``) holds ``n_steps_per_fit`` transitions,
  ``T = n_steps_per_fit / N`` consecutive steps of each env, **env by env** (env 0's ``T`` steps in time
  order, then env 1's, ...), in the arrays of :func:`~baselines.common.fast_trpo.dataset_to_arrays`
  (float32 states, actions, rewards; bool ``absorbing`` and ``last``). ``last`` is true at episode ends and at
  each env's final transition of the batch: there its trajectory segment stops inside an episode, which the GAE
  treats as a truncated end (bootstrapped from the critic unless absorbing), exactly as it treats the final
  transition of a single-env batch. Episodes themselves carry on across fits, as in Core.

Randomness: each env's own generator (start states, randomization, goals; seeded by the caller, see
:func:`env_seeds`) and the policy's exploration generator. Each env's stream is consumed by that env only and
the policy's in one batched draw per step, so the results do not depend on the thread count or timing; a
seeded run is reproducible, and :meth:`BatchedCollector.rng_states` / :meth:`~BatchedCollector.set_rng_states`
(with the agent's state dict, which holds the policy's generator) are what an exact resume needs.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits


def env_seeds(seed: int, n_envs: int) -> list[int]:
    """Seeds of the ``n_envs`` training environments of a run seeded ``seed``: spawned children of
    ``SeedSequence(seed)``, so they differ from each other and from the streams the agent derives from
    ``generate_state`` of the same seed."""
    return [int(child.generate_state(1)[0]) for child in np.random.SeedSequence(seed).spawn(n_envs)]


def default_env_threads(n_envs: int) -> int:
    """Threads stepping the environments: one per available core, at most 2 and at most ``n_envs``."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return max(1, min(2, cores, n_envs))


class EnvThreadPool:
    """``run(fn)`` calls ``fn(i)`` for ``i in range(n_items)``: contiguous chunks, one per thread, the caller's
    thread doing the first; it returns when every chunk is done (re-raising the first error). The workers are
    persistent daemon threads handed work through locks (one release and one acquire per worker and call)."""

    def __init__(self, n_items: int, n_threads: int):
        n_threads = max(1, min(int(n_threads), int(n_items)))
        bounds = [round(k * n_items / n_threads) for k in range(n_threads + 1)]
        self.chunks = [range(bounds[k], bounds[k + 1]) for k in range(n_threads)]
        self._workers = [_Worker(chunk) for chunk in self.chunks[1:]]

    @property
    def n_threads(self) -> int:
        return len(self.chunks)

    def run(self, fn: Callable[[int], Any]) -> None:
        for worker in self._workers:
            worker.submit(fn)
        try:
            for i in self.chunks[0]:
                fn(i)
        finally:  # the workers finish before anything is raised: none touches state after run() returns
            errors = [worker.wait() for worker in self._workers]
        for error in errors:
            if error is not None:
                raise error

    def close(self) -> None:
        for worker in self._workers:
            worker.stop()
        self._workers = []
        self.chunks = [range(self.chunks[0].start, self.chunks[-1].stop)]  # the caller's thread does all


class _Worker(threading.Thread):
    def __init__(self, chunk: range):
        super().__init__(daemon=True, name=f"env-step-{chunk.start}")
        self._chunk = chunk
        self._fn: Callable[[int], Any] | None = None
        self._error: BaseException | None = None
        self._go, self._done = threading.Lock(), threading.Lock()
        self._go.acquire()
        self._done.acquire()
        self.start()

    def submit(self, fn: Callable[[int], Any]) -> None:
        self._fn = fn
        self._go.release()

    def wait(self) -> BaseException | None:
        self._done.acquire()
        error, self._error = self._error, None
        return error

    def stop(self) -> None:
        self._fn = None
        self._go.release()
        self.join()

    def run(self) -> None:
        while True:
            self._go.acquire()
            fn = self._fn
            if fn is None:
                return
            try:
                for i in self._chunk:
                    fn(i)
            except BaseException as err:  # handed to the caller's thread by wait()
                self._error = err
            self._done.release()


class BatchedCollector:
    """``Core.learn`` for an on-policy agent with ``N = len(envs)`` environments; see the module docstring.

    Args:
        agent: an agent with ``fit_arrays`` (the adversarial agents) whose policy has ``draw_actions`` (the
            numpy-sampled :class:`~baselines.common.policy.GaussianPolicy`; other policies are sampled row by
            row through ``agent.draw_action``).
        envs: the environments, same observation and action spaces and horizon, each with its own seed.
        n_threads: threads stepping the environments (1: sequential in the caller's thread); default
            :func:`default_env_threads`.
        callbacks_fit: called after every fit with the batch (the six arrays handed to ``fit_arrays``).
    """

    def __init__(self, agent: Any, envs: Sequence[Any], n_threads: int | None = None,
                 callbacks_fit: Sequence[Callable[[tuple[np.ndarray, ...]], Any]] | None = None):
        if len(envs) < 1:
            raise ValueError("BatchedCollector needs at least one environment")
        if not hasattr(agent, "fit_arrays"):
            raise TypeError(f"{type(agent).__name__} has no fit_arrays: batched collection is for the on-policy "
                            "(adversarial) agents")
        if getattr(agent, "preprocessors", None):
            raise ValueError("BatchedCollector does not apply agent preprocessors")
        info = envs[0].info
        for env in envs[1:]:
            if (env.info.observation_space.shape != info.observation_space.shape
                    or env.info.action_space.shape != info.action_space.shape or env.info.horizon != info.horizon):
                raise ValueError("the environments of a BatchedCollector must share observation and action spaces "
                                 "and horizon")
        self.agent, self.envs = agent, list(envs)
        self.n_envs = len(self.envs)
        self.horizon = info.horizon
        self.obs_dim, self.act_dim = info.observation_space.shape[0], info.action_space.shape[0]
        self.callbacks_fit = list(callbacks_fit or [])
        self._pool = EnvThreadPool(self.n_envs, default_env_threads(self.n_envs) if n_threads is None else n_threads)
        self._state = np.zeros((self.n_envs, self.obs_dim))
        self._episode_steps = [0] * self.n_envs
        self._episodes_per_env = [0] * self.n_envs
        self._buffers: tuple[np.ndarray, ...] = ()
        self._t, self._actions = 0, np.zeros((self.n_envs, self.act_dim))

    @property
    def n_threads(self) -> int:
        return self._pool.n_threads

    @property
    def episodes(self) -> int:
        """Episodes ended (absorbing or at the horizon) since construction, all envs together."""
        return sum(self._episodes_per_env)

    # ---- the loop -------------------------------------------------------------------------------------
    def learn(self, n_steps: int, n_steps_per_fit: int) -> None:
        """Collect ``n_steps`` environment steps (all envs together), fitting every ``n_steps_per_fit``; a
        remainder after the last fit is dropped, as ``Core.learn`` drops it."""
        n = self.n_envs
        if n_steps_per_fit < n or n_steps_per_fit % n:
            raise ValueError(f"n_steps_per_fit ({n_steps_per_fit}) must be a multiple of the number of "
                             f"environments ({n})")
        if n_steps % n:
            raise ValueError(f"n_steps ({n_steps}) must be a multiple of the number of environments ({n})")
        steps_per_env = n_steps_per_fit // n
        self._allocate(steps_per_env)
        # numpy's OpenBLAS threads a product from 2^18 multiply-adds on (the policy's second layer from 4 rows):
        # on busy cores its spinning threads made collection 2-40x slower. One BLAS thread while collecting.
        blas = threadpool_limits(limits=1, user_api="blas")
        try:
            self._reset_all()
            for _ in range(n_steps // n_steps_per_fit):
                self._collect(steps_per_env)
                batch = self._batch()
                self.agent.fit_arrays(*batch)
                for callback in self.callbacks_fit:
                    callback(batch)
            for _ in range((n_steps % n_steps_per_fit) // n):  # Core steps on without a fit, then drops them
                self._collect(1)
        finally:
            blas.restore_original_limits()
            self.agent.stop()

    def _allocate(self, steps_per_env: int) -> None:
        if self._buffers and self._buffers[0].shape[0] == steps_per_env:
            return
        shape = (steps_per_env, self.n_envs)
        self._buffers = (np.zeros((*shape, self.obs_dim), np.float32), np.zeros((*shape, self.act_dim), np.float32),
                         np.zeros(shape, np.float32), np.zeros((*shape, self.obs_dim), np.float32),
                         np.zeros(shape, bool), np.zeros(shape, bool))

    def _reset_all(self) -> None:
        for i, env in enumerate(self.envs):
            self._state[i] = env.reset()
            self._episode_steps[i] = 0

    def _draw_actions(self, states: np.ndarray) -> np.ndarray:
        draw = getattr(self.agent.policy, "draw_actions", None)
        if draw is not None:
            return draw(states)
        return np.stack([self.agent.draw_action(s) for s in states])

    def _collect(self, steps: int) -> None:
        """``steps`` control steps of every env into rows ``0 .. steps-1`` of the buffers (time-major)."""
        x, u = self._buffers[0], self._buffers[1]
        run, step_env = self._pool.run, self._step_env
        for t in range(steps):
            actions = self._draw_actions(self._state)
            x[t] = self._state
            u[t] = actions
            self._t, self._actions = t, actions
            run(step_env)

    def _step_env(self, i: int) -> None:
        """One control step of env ``i`` at time ``self._t`` (runs in a pool thread: touches row ``i`` only)."""
        env, t = self.envs[i], self._t
        _, _, r, xn, absorbing, last = self._buffers
        action = env.apply_action(self._actions[i])
        env.step_physics()
        obs, reward, is_absorbing, _ = env.finish_step(action)
        xn[t, i] = obs
        r[t, i] = reward
        absorbing[t, i] = is_absorbing
        k = self._episode_steps[i] + 1
        is_last = is_absorbing or k >= self.horizon
        last[t, i] = is_last
        if is_last:
            self._state[i] = env.reset()
            self._episode_steps[i] = 0
            self._episodes_per_env[i] += 1
        else:
            self._state[i] = obs
            self._episode_steps[i] = k

    def _batch(self) -> tuple[np.ndarray, ...]:
        """The buffers env by env (each env's steps contiguous), ``last`` set at each env's final transition."""
        n_rows = self._buffers[0].shape[0] * self.n_envs
        out = tuple(np.ascontiguousarray(b.swapaxes(0, 1)).reshape(n_rows, *b.shape[2:]) for b in self._buffers)
        out[5].reshape(self.n_envs, -1)[:, -1] = True
        return out

    # ---- checkpoints ----------------------------------------------------------------------------------
    def rng_states(self) -> list[dict[str, Any]]:
        """Each env's generator state (the policy's is in the agent's state dict)."""
        return [env._rng.bit_generator.state for env in self.envs]

    def set_rng_states(self, states: Sequence[dict[str, Any]]) -> None:
        if len(states) != self.n_envs:
            raise ValueError(f"{len(states)} generator states for {self.n_envs} environments")
        for env, state in zip(self.envs, states, strict=True):
            env._rng.bit_generator.state = state

    def close(self) -> None:
        """Stop the worker threads (the collector then steps its envs sequentially) and the environments."""
        self._pool.close()
        for env in self.envs:
            env.stop()
