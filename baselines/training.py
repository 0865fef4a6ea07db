"""Train an adversarial imitation agent epoch by epoch, with evaluation, logging and exact checkpoints.

A run directory holds ``config.yaml`` (the resolved configuration), ``checkpoint.pt`` (the latest epoch),
``progress.csv`` (one row per epoch: evaluation and training statistics), ``machines.csv`` (the machine of each
start and resume, :mod:`baselines.common.machine`), ``snapshots/<steps>/`` (policy-only exports every
``train.snapshot_every`` steps) and ``tensorboard/``; a warm-started run also keeps
``init_from_progress.csv``, its source's log up to the checkpoint it started from (and its source's machines).

One epoch is one ``Core.learn`` call of ``train.epoch_steps`` steps (it ends on a fit), then a deterministic
evaluation on a separate environment re-seeded with ``train.eval_seed`` (the same start states every epoch; with
the default seed, the protocol's first ``n_eval_episodes``; the log's ``score`` is their normalised score),
then the log row, then the checkpoint (written atomically). A killed run therefore loses at most the epoch in
progress, and resuming restores the agent, the training environment's generator and the global torch / numpy
generators, so it continues exactly as if it had never stopped.

With ``train.n_envs > 1`` (on-policy algorithms) an epoch is one ``BatchedCollector.learn`` call instead
(:mod:`baselines.common.batched`): ``n_envs`` training environments seeded from the run seed
(:func:`~baselines.common.batched.env_seeds`; the first is the environment that gave the expert data, re-seeded),
one batched policy forward per control step, their physics in ``train.env_threads`` threads. Like ``Core.learn``
it resets every environment at its start, so the checkpoint holds each environment's generator (``env_rngs``)
besides the agent's, and a resumed run again continues exactly.
"""

from __future__ import annotations

import csv
import dataclasses
import os
import shutil
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
from mushroom_rl.core import Core
from tqdm import tqdm

from baselines.common.batched import BatchedCollector, env_seeds
from baselines.common.evaluation import evaluate
from baselines.common.expert_data import ExpertData, kinematic_obs_mask
from baselines.common.logger import CSVLogger
from baselines.common.machine import MACHINES, record_machine
from baselines.config import RunConfig
from loco_mujoco.atomic_write import atomic_write
from loco_mujoco.evaluation.protocol import evaluation_env
from loco_mujoco.evaluation.references import references

CHECKPOINT = "checkpoint.pt"
CHECKPOINT_FORMAT = 1
INIT_FROM_PROGRESS = "init_from_progress.csv"  # a warm-started run's copy of its source's log
REPLAY = "replay.npz"  # an off-policy run's replay buffer, beside its checkpoint (large: never committed)
REPLAY_NEXT = "replay.next.npz"  # the buffer being written with the next checkpoint
SNAPSHOTS = "snapshots"  # policy-only exports every train.snapshot_every steps (small: the preference agents)


def make_env(run: RunConfig, seed: int) -> Any:
    from loco_mujoco import LocoEnv

    return LocoEnv.make(run.task, seed=seed, **run.env)


def dataset_identity(env: Any) -> dict[str, Any]:
    """The exact data a run trains on: its file and that file's sha256 (a digest of the states when the dataset
    was joined in memory, e.g. the body sizes of mode ``all``)."""
    import hashlib

    from loco_mujoco.agent_datasets import file_sha256

    ds = env.dataset
    if ds.source_file is not None:
        return {"file": Path(ds.source_file).name, "sha256": file_sha256(ds.source_file)}
    h = hashlib.sha256(np.ascontiguousarray(ds.qpos).tobytes() + np.ascontiguousarray(ds.qvel).tobytes())
    return {"file": None, "states_sha256": h.hexdigest()}


def make_expert(run: RunConfig, env: Any) -> ExpertData:
    """The expert transitions; with ``train.expert_actions: inverse_dynamics`` actions derived by inverse dynamics
    (``auto``: the dataset's actions where it has them, inverse dynamics otherwise)."""
    dataset = env.create_dataset()
    mode = run.train.expert_actions
    if mode == "inverse_dynamics" or (mode == "auto" and "actions" not in dataset):
        from baselines.common.inverse_dynamics import inverse_dynamics_actions

        dataset = {**dataset, "actions": inverse_dynamics_actions(env)}
    from baselines import ALGORITHMS

    if ALGORITHMS[run.algorithm].family != "adversarial":  # no discriminator: policy and critic see everything
        return ExpertData(dataset, np.ones(env.info.observation_space.shape[0], dtype=bool))
    return ExpertData(dataset, kinematic_obs_mask(env))


def build(run: RunConfig) -> tuple[Any, Any]:
    """The training environment and the agent of ``run`` (agent seeded with ``run.seed``)."""
    from baselines import make_agent

    env = make_env(run, seed=run.seed)
    agent = make_agent(run.algorithm, env, config=run.agent, seed=run.seed, expert=make_expert(run, env))
    return env, agent


def build_collector(run: RunConfig, env: Any, agent: Any) -> BatchedCollector:
    """The ``run.train.n_envs`` training environments of a batched run around ``agent``: ``env`` (re-seeded) and
    ``n_envs - 1`` more of the same task and settings, seeds from :func:`~baselines.common.batched.env_seeds`."""
    seeds = env_seeds(run.seed, run.train.n_envs)
    env.seed(seeds[0])
    envs = [env] + [make_env(run, seed=s) for s in seeds[1:]]
    return BatchedCollector(agent, envs, n_threads=run.train.env_threads or None)


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    """A checkpoint written by :class:`Trainer` (tensors and plain values: safe ``weights_only`` loading)."""
    path = Path(path)
    if path.is_dir():
        path = path / CHECKPOINT
    if not path.exists():
        raise FileNotFoundError(f"no checkpoint at {path}")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # noqa: BLE001  (a truncated or foreign file)
        raise ValueError(f"{path} is not a readable checkpoint: {err}") from None
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path} is not a loco_mujoco baselines checkpoint (format {CHECKPOINT_FORMAT})")
    return state


def run_config_from_checkpoint(state: dict[str, Any]) -> RunConfig:
    """The exact configuration a checkpoint was trained with (independent of today's YAML files)."""
    from baselines import ALGORITHMS
    from baselines.config import TrainConfig

    c = migrate_run_config(state["run_config"])
    agent = ALGORITHMS[c["algorithm"]].config_class.from_dict(c["agent"])
    return RunConfig(task=c["task"], algorithm=c["algorithm"], seed=int(c["seed"]), env=dict(c["env"]),
                     train=TrainConfig(**c["train"]), agent=agent, sources=list(c["sources"]),
                     init_from=c.get("init_from"))


def run_config_from_directory(run_dir: str | Path) -> RunConfig:
    """The configuration of the run in ``run_dir``: its checkpoint's, or, for a finished run that keeps only its
    log and export, its ``config.yaml`` (written by the same :class:`Trainer` from the same configuration)."""
    run_dir = Path(run_dir)
    if (run_dir / CHECKPOINT).exists():
        return run_config_from_checkpoint(load_checkpoint(run_dir))
    config = run_dir / "config.yaml"
    if not config.exists():
        raise FileNotFoundError(f"{run_dir} holds neither {CHECKPOINT} nor config.yaml: not a run directory")
    values = yaml.safe_load(config.read_text())
    if not isinstance(values, dict) or not {"task", "algorithm", "seed", "env", "train", "agent"} <= set(values):
        raise ValueError(f"{config} is not a run's resolved configuration (task, algorithm, seed, env, train, agent)")
    return run_config_from_checkpoint({"run_config": {"sources": [], **values}})


def migrate_run_config(c: dict[str, Any]) -> dict[str, Any]:
    """A run config of an older checkpoint in today's layout: ``n_steps_per_fit`` moved from agent to train."""
    c = {**c, "agent": dict(c["agent"]), "train": dict(c["train"])}
    if "n_steps_per_fit" in c["agent"]:
        c["train"]["n_steps_per_fit"] = c["agent"].pop("n_steps_per_fit")
    if c.get("init_from"):
        c["init_from"] = {**c["init_from"], "run_config": migrate_run_config(c["init_from"]["run_config"])}
    return c


@dataclasses.dataclass(frozen=True)
class EpochPace:
    """How long an epoch took: ``learn_s`` seconds of learning for its ``steps`` (and, for an off-policy agent,
    its ``updates``), plus ``other_s`` of evaluation and checkpoint. A later epoch is expected to take as long per
    step, or per update where that says longer: an off-policy epoch that was partly warm-up (steps without
    updates, ~4x faster) would otherwise make a full epoch look shorter than it is."""

    learn_s: float
    steps: int
    updates: int | None = None
    other_s: float = 0.0

    def expected_s(self, steps: int, updates: int | None = None) -> float:
        by_steps = self.learn_s * steps / self.steps
        by_updates = self.learn_s * updates / self.updates if updates is not None and self.updates else 0.0
        return self.other_s + max(by_steps, by_updates)


class Trainer:
    """Runs (or resumes) ``run`` in ``out_dir``; ``train()`` returns the last evaluation.

    ``init_from`` warm-starts a new run from another run's checkpoint (same task and algorithm): the agent's
    weights, optimisers, standardizers and discriminator are loaded, the step count continues from there, and
    the new configuration (e.g. a larger batch per fit) applies from then on. The source is recorded in
    ``run.init_from``. ``n_threads`` replaces a resumed run's torch thread count (results then match the
    uninterrupted run only to floating-point reduction order). ``on_progress(steps)``, if given, hears the steps
    done so far after every fit (gradient steps: every 100), e.g. to show a sweep's trials live;
    ``on_evaluation(steps, figures)`` hears each epoch's evaluation (with the agent's update statistics beside it,
    e.g. ``q_expert``), and what it returns (a line, or None) is printed above the progress bar.
    """

    def __init__(self, run: RunConfig, out_dir: str | Path, resume: bool = False, progress: bool = True,
                 init_from: str | Path | None = None, n_threads: int | None = None,
                 on_progress: Callable[[int], None] | None = None,
                 on_evaluation: Callable[[int, dict[str, float]], str | None] | None = None):
        self.out_dir = Path(out_dir)
        self.on_progress, self.on_evaluation = on_progress, on_evaluation
        self.checkpoint_path = self.out_dir / CHECKPOINT
        state = warm = None
        if resume and init_from is not None:
            raise ValueError("resume continues a run from its own checkpoint; init_from starts a new one: "
                             "give one of them")
        if init_from is not None:
            warm = load_checkpoint(init_from)
            run = dataclasses.replace(run, init_from=_warm_start_record(warm, init_from, run))
        if resume:
            state = load_checkpoint(self.checkpoint_path)
            saved = run_config_from_checkpoint(state)
            if (saved.task, saved.algorithm, saved.seed) != (run.task, run.algorithm, run.seed):
                raise ValueError(f"{self.checkpoint_path} is {saved.algorithm} on {saved.task} seed {saved.seed}, "
                                 f"not {run.algorithm} on {run.task} seed {run.seed}")
            saved.train.n_steps = run.train.n_steps  # what a resume may change: how long to go on,
            saved.train.snapshot_every = run.train.snapshot_every  # how often to keep a policy snapshot,
            if n_threads is not None:  # and how many torch threads the learner uses (speed, not the algorithm)
                saved.agent.n_threads = n_threads
            run = saved
        elif self.checkpoint_path.exists():
            raise FileExistsError(f"{self.checkpoint_path} exists: pass --resume to continue that run, "
                                  f"or choose another --out")
        else:
            _check_fresh_run_dir(self.out_dir)
        self.run = run
        self.progress = progress
        # Normalised score (0 = random, 100 = expert) of every epoch's evaluation; cached per task and settings.
        self.references = references(run.task, run.env)
        # The agent and env own seeded generators; the global ones are seeded too, for any code that uses them.
        torch.manual_seed(run.seed)
        np.random.seed(run.seed)
        self.env, self.agent = build(run)
        self.collector = build_collector(run, self.env, self.agent) if run.train.n_envs > 1 else None
        if hasattr(self.agent, "set_budget"):  # off-policy: the warm-up scales to the run's length
            self.agent.set_budget(run.train.n_steps)
        self.eval_env = evaluation_env(run.task, run.env, seed=run.train.eval_seed)  # the real task's starts
        self.out_dir.mkdir(parents=True, exist_ok=True)  # only now: a start that fails leaves nothing behind
        self.epoch, self.steps, self.wall_s = 0, 0, 0.0
        self.stopped_at_deadline = False  # set by train(deadline=...)
        if state is not None:
            self._restore(state)
            _truncate_csv(self.out_dir / "progress.csv", self.steps)
        else:
            if warm is not None:
                self._warm_start(warm)
            config = {**run.to_dict(), "dataset": dataset_identity(self.env)}
            (self.out_dir / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
        self.logger = CSVLogger(self.out_dir)

    # ---- the loop -------------------------------------------------------------------------------------
    def train(self, deadline: float | None = None) -> dict[str, float]:
        """Train to ``run.train.n_steps``, an evaluation and a checkpoint after every epoch; with ``deadline`` (a
        ``time.time()`` value) stop instead after the last checkpoint whose next epoch is not expected to end by
        then (``stopped_at_deadline`` says so; the run resumes from that checkpoint). The next epoch is expected
        to take as long as this call's last one (learning, evaluation and checkpoint) or, before it, as the epoch
        the run last logged; for an off-policy agent by its updates where they say longer than its steps, so an
        epoch that was half warm-up (no updates) does not make the next one look half as long (:class:`EpochPace`)."""
        run, last_eval = self.run, {}
        self.stopped_at_deadline = False
        pace = self._logged_pace()
        if self.collector is None:
            core = Core(self.agent, self.env, callbacks_fit=[self._on_fit])
        else:
            core, self.collector.callbacks_fit = None, [self._on_fit]
        self._bar = tqdm(total=run.train.n_steps, initial=self.steps, unit="step", dynamic_ncols=True,
                         disable=not self.progress, desc=f"{run.algorithm} {run.task}")
        self._live_steps = self.steps
        record_machine(self.out_dir, self.steps, torch.get_num_threads())
        try:
            while self.steps < run.train.n_steps:
                n = min(run.train.epoch_steps, run.train.n_steps - self.steps)
                n -= n % run.train.n_steps_per_fit
                if n == 0:
                    break
                if deadline is not None and time.time() + self._expected_s(pace, n) > deadline:
                    self.stopped_at_deadline = True
                    break
                updates_before = self._agent_updates()
                epoch_start = start = time.perf_counter()
                self._learn(core, n)
                train_s = time.perf_counter() - start
                self.steps += n
                self.epoch += 1
                self.wall_s += train_s
                last_eval = self.evaluate()
                stats = self.agent.last_stats
                self.logger.log(self.steps, epoch=self.epoch, **last_eval, train_steps_per_s=n / train_s,
                                **{k: v for k, v in stats.items() if k != "fit"})
                self.save()
                every = run.train.snapshot_every
                if every and self.steps // every > (self.steps - n) // every:  # this epoch passed a multiple
                    self.snapshot(last_eval)
                line = (self.on_evaluation(self.steps, {**stats, **last_eval}) if self.on_evaluation is not None
                        else None)
                if line:
                    self._bar.write(line)
                self._bar.set_postfix(score=f"{last_eval['score']:.1f}", L=f"{last_eval['L']:.0f}",
                                      R=f"{last_eval['R']:.1f}",
                                      task_r=f"{last_eval['task_reward']:.3f}")
                updates = None if updates_before is None else self._agent_updates() - updates_before
                pace = EpochPace(train_s, n, updates, other_s=time.perf_counter() - epoch_start - train_s)
        finally:
            self._bar.close()
            self.agent.stop()
            self.logger.close()
            if self.collector is not None:
                self.collector.close()  # its worker threads; a later train() steps the envs in this thread
        return last_eval

    def _logged_pace(self) -> EpochPace | None:
        """The pace of the last epoch in the run's log: its steps over the logged learning rate, and its updates
        where the log counts them (None: no log yet)."""
        path = self.out_dir / "progress.csv"
        if not path.exists():
            return None
        with path.open(newline="") as f:
            rows = [r for r in csv.DictReader(f) if r.get("train_steps_per_s")]
        if not rows or float(rows[-1]["train_steps_per_s"]) <= 0:
            return None
        last, epoch_steps = rows[-1], self.run.train.epoch_steps
        rate = float(last["train_steps_per_s"])
        before = rows[-2] if len(rows) > 1 else {"step": "0", "updates": "0"}  # one row: the epoch from step 0
        steps = int(float(last["step"])) - int(float(before["step"]))
        if not 0 < steps <= epoch_steps:  # a warm start's first row (its counts continue another run's) or odd rows
            return EpochPace(epoch_steps / rate, epoch_steps)
        updates = None
        if last.get("updates") and before.get("updates") and self._agent_updates() is not None:
            updates = int(float(last["updates"])) - int(float(before["updates"]))
        return EpochPace(steps / rate, steps, updates)

    def _agent_updates(self) -> int | None:
        """The updates an off-policy agent has made so far (None for agents whose cost is per step)."""
        return int(self.agent.updates) if hasattr(self.agent, "updates_in") else None

    def _expected_s(self, pace: EpochPace | None, n: int) -> float:
        """Seconds the next epoch of ``n`` steps is expected to take (0 when nothing has been measured yet)."""
        if pace is None:
            return 0.0
        return pace.expected_s(n, self.agent.updates_in(n) if pace.updates is not None else None)

    def _learn(self, core: Core | None, n: int) -> None:
        """``n`` steps of training: environment steps for on-policy agents (``Core`` with one env, or the batched
        collector), gradient steps for offline ones."""
        if getattr(self.agent, "offline", False):
            self.agent.fit_offline(n, callback=self._advance)
        elif self.collector is not None:
            self.collector.learn(n_steps=n, n_steps_per_fit=self.run.train.n_steps_per_fit)
        else:
            core.learn(n_steps=n, n_steps_per_fit=self.run.train.n_steps_per_fit, quiet=True)

    def _on_fit(self, dataset: Any) -> None:
        self._advance(self.run.train.n_steps_per_fit)

    def _advance(self, n: int) -> None:
        """``n`` more steps of the epoch in progress: the bar moves and ``on_progress`` hears the total."""
        self._bar.update(n)
        self._live_steps += n
        if self.on_progress is not None:
            self.on_progress(self._live_steps)

    def evaluate(self) -> dict[str, float]:
        """Deterministic (and optionally stochastic) evaluation on the evaluation env, re-seeded each time."""
        t = self.run.train
        self.eval_env.seed(t.eval_seed)
        det = evaluate(self.agent, self.eval_env, n_episodes=t.n_eval_episodes, deterministic=True, seed=t.eval_seed)
        out = {k: v for k, v in det.items() if k != "deterministic"}
        out["score"] = float(self.references.normalized_score(det["R"]))
        if t.n_eval_episodes_stochastic:
            self.eval_env.seed(t.eval_seed)
            sto = evaluate(self.agent, self.eval_env, n_episodes=t.n_eval_episodes_stochastic, deterministic=False,
                           seed=t.eval_seed)
            out.update({f"stochastic_{k}": v for k, v in sto.items() if k != "deterministic"})
        return out

    # ---- checkpoints ----------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        state = {"format": CHECKPOINT_FORMAT, "run_config": self.run.to_dict(), "env_name": self.run.task,
                 "epoch": self.epoch, "steps": self.steps, "wall_s": self.wall_s,
                 "agent": self.agent.state_dict(), "env_rng": self.env._rng.bit_generator.state,
                 "torch_rng": torch.get_rng_state(), "numpy_rng": _numpy_global_state()}
        if self.collector is not None:  # every training environment's generator (env_rng: the first one's)
            state["env_rngs"] = self.collector.rng_states()
        return state

    def save(self) -> None:
        buffered = hasattr(self.agent, "save_buffer")  # off-policy: the replay buffer beside the checkpoint
        if buffered:  # written in full first, then both files swapped in: a kill leaves a matching pair
            self.agent.save_buffer(self.out_dir / REPLAY_NEXT)
        with atomic_write(self.checkpoint_path, "wb") as f:
            torch.save(self.state_dict(), f)
        if buffered:
            os.replace(self.out_dir / REPLAY_NEXT, self.out_dir / REPLAY)

    def snapshot(self, figures: dict[str, float]) -> Path:
        """Export the current policy to ``snapshots/<steps>/`` with this epoch's evaluation figures on its card
        (``training_evaluation``: the run's own deterministic episodes, not the protocol's)."""
        from baselines.export import export_agent, run_card

        card = run_card(self.run, self.steps, source_run=self.out_dir.as_posix(), epoch=self.epoch,
                        training_evaluation={k: float(v) for k, v in figures.items()})
        return export_agent(self.agent, self.out_dir / SNAPSHOTS / str(self.steps), card, self.run.to_dict(),
                            overwrite=True)

    def _restore_buffer(self) -> None:
        """The replay buffer saved with the checkpoint; without it (only the committed small state survived) the run
        goes on as a documented warm start, and says so."""
        candidates = [p for p in (self.out_dir / REPLAY, self.out_dir / REPLAY_NEXT) if p.exists()]
        if not candidates:
            _replay_notice(self, f"no {REPLAY} beside the checkpoint")
            return
        for path in candidates:  # REPLAY_NEXT matches when a kill fell between the two renames of save()
            try:
                self.agent.load_buffer(path)
                return
            except ValueError as err:
                reason = str(err)
        _replay_notice(self, reason)

    def _warm_start(self, state: dict[str, Any]) -> None:
        try:
            self.agent.load_state_dict(state["agent"])
        except RuntimeError as err:  # tensor shapes differ: another network architecture
            raise ValueError(f"cannot warm-start from {self.run.init_from['checkpoint']}: its networks do not "
                             f"match this configuration ({str(err).splitlines()[0]})") from None
        self.epoch, self.steps, self.wall_s = int(state["epoch"]), int(state["steps"]), float(state["wall_s"])
        source_log = Path(self.run.init_from["checkpoint"]).parent / "progress.csv"
        if source_log.exists():  # the source's curve up to the checkpoint, so the whole history stays together
            shutil.copy(source_log, self.out_dir / INIT_FROM_PROGRESS)
            _truncate_csv(self.out_dir / INIT_FROM_PROGRESS, self.steps)
        if (source_log.parent / MACHINES).exists():  # and its machines (train() drops rows past the loaded step)
            shutil.copy(source_log.parent / MACHINES, self.out_dir / MACHINES)

    def _restore(self, state: dict[str, Any]) -> None:
        self.agent.load_state_dict(state["agent"])
        if hasattr(self.agent, "load_buffer"):
            self._restore_buffer()
        self.env._rng.bit_generator.state = state["env_rng"]
        if self.collector is not None:
            self.collector.set_rng_states(state["env_rngs"])
        torch.set_rng_state(state["torch_rng"])
        _set_numpy_global_state(state["numpy_rng"])
        self.epoch, self.steps, self.wall_s = int(state["epoch"]), int(state["steps"]), float(state["wall_s"])


def _replay_notice(trainer: Trainer, reason: str) -> None:
    warnings.warn(f"{trainer.out_dir}: {reason}; --resume continues as a warm start: networks, optimisers and "
                  f"temperature restored, the replay buffer refilled for {getattr(trainer.agent, 'warmup', 0):,} "
                  "transitions before updates resume (not bit-identical to an uninterrupted run)", stacklevel=3)


def _warm_start_record(state: dict[str, Any], path: str | Path, run: RunConfig) -> dict[str, Any]:
    """What ``RunConfig.init_from`` records of the source checkpoint; raises if it cannot seed ``run``."""
    source = run_config_from_checkpoint(state)
    if (source.task, source.algorithm) != (run.task, run.algorithm):
        raise ValueError(f"{path} is {source.algorithm} on {source.task}; it cannot warm-start {run.algorithm} "
                         f"on {run.task}")
    if run.train.n_steps <= int(state["steps"]):
        raise ValueError(f"{path} has already trained {int(state['steps']):,} steps; train.n_steps "
                         f"({run.train.n_steps:,}) must be larger to go on from it")
    path = Path(path) / CHECKPOINT if Path(path).is_dir() else Path(path)
    return {"checkpoint": str(path.resolve()), "epoch": int(state["epoch"]), "steps": int(state["steps"]),
            "run_config": source.to_dict()}


RUN_FILES = (CHECKPOINT, "progress.csv", "config.yaml", INIT_FROM_PROGRESS, MACHINES, "tensorboard", REPLAY,
             SNAPSHOTS)


def _check_fresh_run_dir(out_dir: Path) -> None:
    """A new run's folder holds no other run's files, and it can be written; raise before any work if not."""
    found = [name for name in RUN_FILES if (out_dir / name).exists()]
    if found:
        raise FileExistsError(f"{out_dir} holds another run's files ({', '.join(found)}) but no checkpoint to "
                              "resume; a run folder belongs to one run: choose another --out")
    writable_dir(out_dir)


def writable_dir(path: Path) -> None:
    """Raise ``PermissionError`` naming ``path`` if it (or, when missing, its nearest existing parent) cannot be
    written, or ``NotADirectoryError`` if it is a file."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(f"{path} is a file, not a folder")
    probe = path
    while not probe.exists():
        probe = probe.parent
    if not os.access(probe, os.W_OK | os.X_OK):
        raise PermissionError(f"cannot write to {path}: {probe} is not writable")


def _numpy_global_state() -> dict[str, Any]:
    name, keys, pos, has_gauss, cached = np.random.get_state()
    return {"name": name, "keys": torch.from_numpy(keys.astype(np.int64)), "pos": int(pos),
            "has_gauss": int(has_gauss), "cached_gaussian": float(cached)}


def _set_numpy_global_state(s: dict[str, Any]) -> None:
    np.random.set_state((s["name"], s["keys"].numpy().astype(np.uint32), s["pos"], s["has_gauss"],
                         s["cached_gaussian"]))


def _truncate_csv(path: Path, max_step: int) -> None:
    """Drop rows logged after the checkpoint (an epoch whose checkpoint was never written)."""
    if not path.exists():
        return
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        fields, rows = reader.fieldnames or [], [r for r in reader if int(r["step"]) <= max_step]
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
