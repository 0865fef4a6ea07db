"""Dynamics randomization from a YAML file, applied to the compiled MjModel in place at every reset.

A config names joints, bodies and geoms (or a ``Default`` section for all of them, minus ``exclude``)
and, per parameter, one distribution around the nominal value::

    Default:
      Joints: {exclude: [], damping: {uniform_range_delta: 0.5}, armature: {sigma: 0.01}}
      Bodies: {exclude: [world], mass: {uniform_range_delta: 0.1, relative: true}}
      Geoms:  {exclude: [floor], friction: {uniform_range: [0.6, 1.2]}}
    Joints: {left_knee: {damping: {sigma: 1.0}}}
    Global: {floor_friction: {uniform_range: [0.5, 1.1]}, gravity: {sigma: 0.1}}

Distributions: ``sigma`` (Gaussian around the nominal), ``uniform_range: [lo, hi]`` (absolute values),
``uniform_range_delta: d`` or ``[lo, hi]`` (nominal + uniform in [-d, d] or [lo, hi]). With
``relative: true`` sigma, ranges and deltas are fractions of the nominal (a range multiplies it).
Samples are clipped at zero where a negative value is unphysical (masses, inertias, damping ...).

Everything that depends on the changed quantities (composite inertias, mass-matrix diagonal, contact
weights, actuator accelerations ...) is recomputed with ``mj_setConst``, exactly as compilation would.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import yaml

from loco_mujoco import strict_yaml
from loco_mujoco.models.spec_edit import dof_width
from loco_mujoco.rotations import mat_to_quat, quat_to_mat

JOINT_PARAMS = ("damping", "stiffness", "frictionloss", "armature")
BODY_PARAMS = ("mass", "diaginertia", "fullinertia")
GEOM_PARAMS = ("friction", "mass", "density")
GLOBAL_PARAMS = ("floor_friction", "gravity")
SECTIONS = {"Joints": JOINT_PARAMS, "Bodies": BODY_PARAMS, "Geoms": GEOM_PARAMS}
_DIST_KEYS = ("sigma", "uniform_range", "uniform_range_delta")
_MIN_INERTIA = 1e-8
_TRIANGLE_MARGIN = 1e-5
_DEFAULT_DENSITY = 1000.0  # MuJoCo's default geom density: a geom's nominal mass is this times its volume


class RandomizationConfigError(ValueError):
    """A randomization config is malformed or names things the model does not have."""


@dataclass(frozen=True)
class Distribution:
    """One parameter's distribution around its nominal value."""

    kind: str  # sigma | uniform_range | uniform_range_delta
    lo: float
    hi: float  # sigma: lo == hi == sigma
    relative: bool = False

    def sample(self, nominal: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        nominal = np.asarray(nominal, dtype=float)
        if self.kind == "sigma":
            noise = rng.normal(0.0, self.lo, size=nominal.shape)
            return nominal * (1.0 + noise) if self.relative else nominal + noise
        if self.kind == "uniform_range":
            draw = rng.uniform(self.lo, self.hi, size=nominal.shape)
            return nominal * draw if self.relative else draw
        draw = rng.uniform(self.lo, self.hi, size=nominal.shape)
        return nominal * (1.0 + draw) if self.relative else nominal + draw


def _parse_distribution(where: str, spec: Any) -> Distribution:
    if not isinstance(spec, Mapping):
        raise RandomizationConfigError(f"{where}: expected a mapping with one of {list(_DIST_KEYS)}, got {spec!r}")
    unknown = set(spec) - set(_DIST_KEYS) - {"relative"}
    if unknown:
        raise RandomizationConfigError(f"{where}: unknown keys {sorted(unknown)}; valid: {[*_DIST_KEYS, 'relative']}")
    kinds = [k for k in _DIST_KEYS if k in spec]
    if len(kinds) != 1:
        raise RandomizationConfigError(f"{where}: give exactly one of {list(_DIST_KEYS)}, got {kinds or 'none'}")
    kind, value = kinds[0], spec[kinds[0]]
    relative = spec.get("relative", False)
    if not isinstance(relative, bool):
        raise RandomizationConfigError(f"{where}: 'relative' must be true or false, got {relative!r}")
    if kind == "sigma":
        if not _is_number(value) or value < 0:
            raise RandomizationConfigError(f"{where}: sigma must be a number >= 0, got {value!r}")
        return Distribution(kind, float(value), float(value), relative)
    if kind == "uniform_range_delta" and _is_number(value):
        if value < 0:
            raise RandomizationConfigError(f"{where}: uniform_range_delta must be >= 0, got {value!r}")
        return Distribution(kind, -float(value), float(value), relative)
    if not (isinstance(value, (list, tuple)) and len(value) == 2 and all(_is_number(v) for v in value)):
        raise RandomizationConfigError(f"{where}: {kind} must be [lo, hi] (numbers), got {value!r}")
    lo, hi = float(value[0]), float(value[1])
    if not lo <= hi:
        raise RandomizationConfigError(f"{where}: {kind} needs lo <= hi, got [{lo}, {hi}]")
    return Distribution(kind, lo, hi, relative)


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)


def _check_params(where: str, entry: Any, valid: tuple[str, ...], extra: tuple[str, ...] = ()) -> dict:
    if entry is None:
        return {}
    if not isinstance(entry, Mapping):
        raise RandomizationConfigError(f"{where}: expected a mapping of parameters, got {entry!r}")
    unknown = set(entry) - set(valid) - set(extra)
    if unknown:
        hint = difflib.get_close_matches(next(iter(unknown)), list(valid), n=1)
        raise RandomizationConfigError(f"{where}: unknown parameters {sorted(unknown)}"
                                       + (f" (did you mean {hint[0]!r}?)" if hint else "") + f"; valid: {list(valid)}")
    return dict(entry)


def _names(model: mujoco.MjModel, objtype: mujoco.mjtObj, count: int) -> list[str]:
    return [mujoco.mj_id2name(model, objtype, i) or "" for i in range(count)]


def default_config_path(env_cls: type) -> Path:
    """The shipped config of an embodiment (its own or its nearest base class's)."""
    folder = resources.files("loco_mujoco") / "configs" / "randomization"
    for cls in env_cls.__mro__:
        path = Path(str(folder / f"{cls.__name__}.yaml"))
        if path.is_file():
            return path
    raise RandomizationConfigError(f"no shipped randomization config for {env_cls.__name__} in {folder}")


def load_config(source: str | Path | Mapping, env_cls: type) -> dict:
    """A config mapping from ``'default'``, a YAML path, or a mapping."""
    if isinstance(source, Mapping):
        return dict(source)
    path = default_config_path(env_cls) if str(source) == "default" else Path(source)
    if not path.is_file():
        raise RandomizationConfigError(f"randomization config {path} not found; give a YAML file path, "
                                       "a mapping, or 'default' for the shipped config")
    try:
        config = strict_yaml.load(path.read_text())
    except strict_yaml.DuplicateKeyError as err:
        raise RandomizationConfigError(f"{path}: {err}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise RandomizationConfigError(f"{path}: not valid YAML: {err}") from err
    if not isinstance(config, Mapping):
        raise RandomizationConfigError(f"{path}: the top level must be a mapping of sections "
                                       f"{['Default', *SECTIONS, 'Global']}")
    return dict(config)


class DomainRandomizer:
    """Samples a config's parameters and writes them into an MjModel; restores the nominal values after."""

    def __init__(self, config: Mapping, model: mujoco.MjModel, floor_geom: str = "floor",
                 never: Mapping[str, tuple[str, ...]] | None = None):
        """``never``: names per section ("Bodies" ...) that no config may touch (e.g. a carried load)."""
        unknown = set(config) - {"Default", *SECTIONS, "Global"}
        if unknown:
            raise RandomizationConfigError(f"unknown sections {sorted(unknown)}; valid: "
                                           f"{['Default', *SECTIONS, 'Global']}")
        self.model = model
        self._floor = model.geom(floor_geom).id if floor_geom in _names(model, mujoco.mjtObj.mjOBJ_GEOM,
                                                                       model.ngeom) else -1
        never = never or {}
        names = {"Joints": _names(model, mujoco.mjtObj.mjOBJ_JOINT, model.njnt),
                 "Bodies": _names(model, mujoco.mjtObj.mjOBJ_BODY, model.nbody),
                 "Geoms": _names(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom)}
        default = config.get("Default") or {}
        if not isinstance(default, Mapping) or set(default) - set(SECTIONS):
            raise RandomizationConfigError(f"Default: expected sections among {list(SECTIONS)}, got "
                                           f"{list(default) if isinstance(default, Mapping) else default!r}")
        # (section, element id, parameter) -> Distribution
        self.plan: dict[tuple[str, int, str], Distribution] = {}
        for section, valid in SECTIONS.items():
            listed = config.get(section) or {}
            if not isinstance(listed, Mapping):
                raise RandomizationConfigError(f"{section}: expected a mapping of names, got {listed!r}")
            for name in listed:
                if name not in names[section]:
                    close = difflib.get_close_matches(str(name), names[section], n=3)
                    raise RandomizationConfigError(
                        f"{section}: no {section[:-1].lower()} named {name!r} in the model"
                        + (f"; did you mean {', '.join(map(repr, close))}?" if close else ""))
            block = _check_params(f"Default.{section}", default.get(section), valid, ("exclude",))
            exclude = block.pop("exclude", []) or []
            if not isinstance(exclude, list):
                raise RandomizationConfigError(f"Default.{section}.exclude must be a list of names, got {exclude!r}")
            for name in exclude:
                if name not in names[section]:
                    raise RandomizationConfigError(f"Default.{section}.exclude: no {section[:-1].lower()} "
                                                   f"named {name!r} in the model")
            default_dists = {p: _parse_distribution(f"Default.{section}.{p}", d) for p, d in block.items()}
            skip = set(exclude) | set(never.get(section, ())) | set(listed)
            for i, name in enumerate(names[section]):
                if self._skip_implicitly(section, i) or name in skip:
                    continue
                for param, dist in default_dists.items():
                    self.plan[(section, i, param)] = dist
            for name, params in listed.items():
                if name in never.get(section, ()):
                    raise RandomizationConfigError(f"{section}.{name} is set by the environment and cannot be "
                                                   "randomized")
                params = _check_params(f"{section}.{name}", params, valid)
                i = names[section].index(name)
                for param, d in params.items():
                    self.plan[(section, i, param)] = _parse_distribution(f"{section}.{name}.{param}", d)
        for section, i, param in self.plan:
            self._check_applicable(section, i, param, names[section][i])
        glob = _check_params("Global", config.get("Global"), GLOBAL_PARAMS)
        self.global_plan = {p: _parse_distribution(f"Global.{p}", d) for p, d in glob.items()}
        if "floor_friction" in self.global_plan and self._floor < 0:
            raise RandomizationConfigError(f"Global.floor_friction: the model has no geom named {floor_geom!r}")
        self._saved: dict[str, np.ndarray] | None = None
        # The plan grouped by (section, parameter, distribution), for one vectorised draw per group at reset;
        # joint parameters other than stiffness live on dofs, whose indices are computed here once.
        grouped: dict[tuple[str, str, Distribution], list[int]] = {}
        for (section, i, param), dist in self.plan.items():
            grouped.setdefault((section, param, dist), []).append(i)
        self._groups = {key: np.array(ids, dtype=np.intp) for key, ids in grouped.items()}
        self._group_dofs = {key: np.concatenate([np.arange(model.jnt_dofadr[j],
                                                           model.jnt_dofadr[j] + dof_width(model.jnt_type[j]))
                                                 for j in ids])
                            for key, ids in self._groups.items() if key[0] == "Joints" and key[1] != "stiffness"}

    def _skip_implicitly(self, section: str, i: int) -> bool:
        """Default sections leave out what has no such parameter: the world body, the free root, the floor."""
        m = self.model
        if section == "Bodies":
            return i == 0
        if section == "Joints":
            return m.jnt_type[i] == mujoco.mjtJoint.mjJNT_FREE
        return i == self._floor

    def _check_applicable(self, section: str, i: int, param: str, name: str) -> None:
        m = self.model
        if section == "Joints" and m.jnt_type[i] == mujoco.mjtJoint.mjJNT_FREE and param in ("stiffness",):
            raise RandomizationConfigError(f"Joints.{name}.{param}: a free joint has no {param}")
        if section == "Geoms" and param in ("mass", "density"):
            if mujoco.mjtGeom(int(m.geom_type[i])) not in _VOLUME:
                raise RandomizationConfigError(f"Geoms.{name}.{param}: only primitive geoms have a volume "
                                               f"(box, sphere, capsule, cylinder, ellipsoid)")
            if m.geom_bodyid[i] == 0:
                raise RandomizationConfigError(f"Geoms.{name}.{param}: the geom belongs to the world body")

    # ---- per reset --------------------------------------------------------------------------------
    _FIELDS = ("dof_damping", "jnt_stiffness", "dof_frictionloss", "dof_armature", "body_mass", "body_inertia",
               "body_iquat", "body_ipos", "geom_friction")

    def restore(self) -> bool:
        """Write back the values that were in the model before the last :meth:`apply`; False if none were saved.

        The caller recomputes the derived constants (``mj_setConst``) before simulating again.
        """
        if self._saved is None:
            return False
        m = self.model
        for name, value in self._saved.items():
            if name == "gravity":
                m.opt.gravity[:] = value
            else:
                getattr(m, name)[...] = value
        self._saved = None
        return True

    def apply(self, rng: np.random.Generator, data: mujoco.MjData) -> None:
        """Sample every planned parameter around the model's current (nominal) values and write it in place."""
        m = self.model
        self._saved = {name: getattr(m, name).copy() for name in self._FIELDS}
        self._saved["gravity"] = m.opt.gravity.copy()
        for key, ids in self._groups.items():
            self._apply_group(key, ids, rng)
        if "floor_friction" in self.global_plan:
            f = self.global_plan["floor_friction"].sample(m.geom_friction[self._floor, :1], rng)
            m.geom_friction[self._floor, 0] = max(float(f[0]), 0.0)
        if "gravity" in self.global_plan:
            m.opt.gravity[2] = float(self.global_plan["gravity"].sample(m.opt.gravity[2:3], rng)[0])
        mujoco.mj_setConst(m, data)

    def _apply_group(self, key: tuple[str, str, Distribution], ids: np.ndarray, rng: np.random.Generator) -> None:
        m = self.model
        section, param, dist = key
        if section == "Joints":
            if param == "stiffness":
                m.jnt_stiffness[ids] = np.maximum(dist.sample(m.jnt_stiffness[ids], rng), 0.0)
                return
            dofs = self._group_dofs[key]
            field = {"damping": m.dof_damping, "frictionloss": m.dof_frictionloss, "armature": m.dof_armature}[param]
            field[dofs] = np.maximum(dist.sample(field[dofs], rng), 0.0)
            return
        if section == "Bodies":
            if param == "mass":
                m.body_mass[ids] = np.maximum(dist.sample(m.body_mass[ids], rng), 0.0)
            elif param == "diaginertia":
                m.body_inertia[ids] = _satisfy_triangle(np.maximum(dist.sample(m.body_inertia[ids], rng),
                                                                   _MIN_INERTIA))
            else:
                for b in ids:  # full inertia: perturb the six tensor entries, then re-diagonalise
                    full = _full_inertia(m.body_inertia[b], m.body_iquat[b])
                    entries = dist.sample(full[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]], rng)
                    full = np.array([[entries[0], entries[3], entries[4]], [entries[3], entries[1], entries[5]],
                                     [entries[4], entries[5], entries[2]]])
                    m.body_inertia[b], m.body_iquat[b] = _principal(full)
            return
        if param == "friction":
            m.geom_friction[ids, 0] = np.maximum(dist.sample(m.geom_friction[ids, 0], rng), 0.0)
            return
        for g in ids:  # geom mass/density: the change from its nominal solid mass goes to its body
            volume = _VOLUME[mujoco.mjtGeom(int(m.geom_type[g]))](m.geom_size[g])
            nominal = _DEFAULT_DENSITY * volume
            if param == "density":
                new_mass = max(float(dist.sample(np.array([_DEFAULT_DENSITY]), rng)[0]), 0.0) * volume
            else:
                new_mass = max(float(dist.sample(np.array([nominal]), rng)[0]), 0.0)
            _add_solid(m, g, new_mass - nominal)


def _full_inertia(diag: np.ndarray, iquat: np.ndarray) -> np.ndarray:
    rot = quat_to_mat(iquat)
    return rot @ np.diag(diag) @ rot.T


def _principal(full: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments and frame of a symmetric inertia, made physical: positive definite and satisfying
    the triangle inequality (each moment at most the sum of the other two)."""
    full = 0.5 * (full + full.T)
    values, vectors = np.linalg.eigh(full)
    values = _satisfy_triangle(np.maximum(values, _MIN_INERTIA)[None])[0]
    if np.linalg.det(vectors) < 0:
        vectors[:, 0] = -vectors[:, 0]
    return values, mat_to_quat(vectors)


def _satisfy_triangle(moments: np.ndarray) -> np.ndarray:
    """Principal moments (n, 3) made physical: where the largest exceeds the sum of the other two, raise the
    smallest so that the sum exceeds it by a margin that survives rounding (MJCF prints 6 digits)."""
    moments = np.array(moments, dtype=float)
    order = np.argsort(moments, axis=1)
    rows = np.arange(len(moments))
    small, mid, big = (moments[rows, order[:, k]] for k in range(3))
    deficit = big * (1.0 + _TRIANGLE_MARGIN) - small - mid
    fix = deficit > 0
    moments[rows[fix], order[fix, 0]] += deficit[fix]
    return moments


def _box_volume(s: np.ndarray) -> float:
    return 8.0 * s[0] * s[1] * s[2]


_VOLUME = {
    mujoco.mjtGeom.mjGEOM_BOX: _box_volume,
    mujoco.mjtGeom.mjGEOM_SPHERE: lambda s: 4.0 / 3.0 * np.pi * s[0] ** 3,
    mujoco.mjtGeom.mjGEOM_ELLIPSOID: lambda s: 4.0 / 3.0 * np.pi * s[0] * s[1] * s[2],
    mujoco.mjtGeom.mjGEOM_CYLINDER: lambda s: np.pi * s[0] ** 2 * 2.0 * s[1],
    mujoco.mjtGeom.mjGEOM_CAPSULE: lambda s: np.pi * s[0] ** 2 * (2.0 * s[1] + 4.0 / 3.0 * s[0]),
}


def _add_solid(m: mujoco.MjModel, g: int, mass: float) -> None:
    """Add (or, with a negative mass, remove) a point-like solid of ``mass`` at geom ``g``'s centre to its body,
    updating the body's mass, centre of mass and inertia (parallel-axis theorem)."""
    b = int(m.geom_bodyid[g])
    m0, c0 = float(m.body_mass[b]), m.body_ipos[b].copy()
    new_mass = m0 + mass
    if new_mass <= 1e-9:
        raise RandomizationConfigError(f"randomizing geom {g}'s mass would leave body {b} with mass {new_mass:.3g}")
    p = m.geom_pos[g]
    c1 = (m0 * c0 + mass * p) / new_mass
    def shift(d: np.ndarray) -> np.ndarray:  # inertia of a unit point mass at offset d
        return np.dot(d, d) * np.eye(3) - np.outer(d, d)

    inertia = _full_inertia(m.body_inertia[b], m.body_iquat[b]) + m0 * shift(c0 - c1) + mass * shift(p - c1)
    m.body_mass[b] = new_mass
    m.body_ipos[b] = c1
    m.body_inertia[b], m.body_iquat[b] = _principal(inertia)
