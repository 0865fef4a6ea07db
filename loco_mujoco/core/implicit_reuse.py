"""Implicit integration that builds and factorises the velocity derivative once per control step.

MuJoCo's implicit integrators solve ``(M - h D) qacc = f`` at every physics step, where ``D = d(force)/d(qvel)``.
For the musculoskeletal model ``D`` holds the muscles' force-velocity damping through their moment arms (80
muscles): building and factorising it is about a third of a 5 ms step. :func:`step_reusing_factor` builds it in
the first physics step of a control step, as ``mj_step`` does, and reuses that factorisation in the others
(MuJoCo's own ``mj_implicitSkip(m, d, skipfactor=1)``, which its finite-difference derivatives use): the matrix
is then ``h`` seconds old, while forces, constraints and the right-hand side are recomputed as usual. The
trade-off is measured in BENCHMARKS.md (speed) and ``bench/timestep_study.py`` (joint-speed spikes, accuracy).

``mj_implicitSkip`` and the step checks are exported by libmujoco but not wrapped by its Python bindings, so they
are called through ``ctypes`` on the models' and datas' addresses.
"""

from __future__ import annotations

import ctypes
import functools
from pathlib import Path

import mujoco

IMPLICIT_INTEGRATORS = (mujoco.mjtIntegrator.mjINT_IMPLICIT, mujoco.mjtIntegrator.mjINT_IMPLICITFAST)


@functools.cache
def _libmujoco() -> ctypes.CDLL:
    """libmujoco of the installed ``mujoco`` package, with the signatures this module calls."""
    folder = Path(mujoco.__file__).parent
    candidates = sorted(folder.glob("libmujoco.so*")) + sorted(folder.glob("libmujoco*.dylib")) + sorted(
        folder.glob("mujoco.dll"))
    if not candidates:
        raise ImportError(f"reusing the implicit factorisation needs libmujoco; none found in {folder}")
    lib = ctypes.CDLL(str(candidates[0]))
    for name, args in (("mj_implicitSkip", (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int)),
                       ("mj_checkPos", (ctypes.c_void_p, ctypes.c_void_p)),
                       ("mj_checkVel", (ctypes.c_void_p, ctypes.c_void_p)),
                       ("mj_checkAcc", (ctypes.c_void_p, ctypes.c_void_p))):
        try:
            function = getattr(lib, name)
        except AttributeError as error:
            raise ImportError(f"mujoco {mujoco.__version__}'s {candidates[0].name} does not export {name}, which "
                              "reusing the implicit factorisation needs") from error
        function.argtypes, function.restype = args, None
    return lib


def check_supported(model: mujoco.MjModel) -> None:
    """Raise ``ValueError`` unless ``model`` integrates implicitly (the only integrators with a factorisation);
    ``ImportError`` if libmujoco lacks the functions needed."""
    if model.opt.integrator not in IMPLICIT_INTEGRATORS:
        names = [mujoco.mjtIntegrator(i).name for i in IMPLICIT_INTEGRATORS]
        raise ValueError(f"reusing the implicit factorisation needs integrator {' or '.join(names)}, the model has "
                         f"{mujoco.mjtIntegrator(model.opt.integrator).name}")
    if not (hasattr(model, "_address") and hasattr(mujoco.MjData, "_address")):
        raise ImportError(f"mujoco {mujoco.__version__}'s bindings do not expose model/data addresses")
    _libmujoco()


def step_reusing_factor(model: mujoco.MjModel, data: mujoco.MjData, n_substeps: int) -> None:
    """``mj_step(model, data, n_substeps)``, except that physics steps 2..n reuse the first one's factorisation of
    ``M - h D`` (the same checks, forward pass and integration otherwise). Call :func:`check_supported` once."""
    mujoco.mj_step(model, data)
    if n_substeps < 2:
        return
    lib, m, d = _libmujoco(), model._address, data._address
    for _ in range(n_substeps - 1):
        lib.mj_checkPos(m, d)
        lib.mj_checkVel(m, d)
        mujoco.mj_forward(model, data)
        lib.mj_checkAcc(m, d)
        lib.mj_implicitSkip(m, d, 1)
