"""Reset cost of dynamics randomization: in place on the compiled model vs re-compiling it from XML.

Per environment, with the shipped config (``domain_randomization_config="default"``):
- in place: mean wall time of ``env.reset()`` (sample, write into the MjModel, ``mj_setConst``, set the
  start state) over --resets resets;
- from XML: what a reset costs when the same sampled parameters are written into the model description
  and the model is rebuilt, as the reference implementation did at every reset: edit the MjSpec, write
  it as MJCF, ``MjModel.from_xml_path`` (meshes read from the original files), ``MjData``. Best case for
  that path: the spec is already built. Each rebuilt model is checked to hold
  the same randomized values as the in-place one.

    .venv/bin/python bench/randomization_reset.py [--env UnitreeH1.walk ...] [--resets 300] [--rebuilds 5]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import mujoco
import numpy as np

from loco_mujoco import LocoEnv

DEFAULT_ENVS = ["UnitreeH1.walk", "Talos.walk", "UnitreeA1.simple", "Atlas.walk", "HumanoidTorque.walk",
                "HumanoidMuscle.walk"]


def write_into_spec(spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """Copy the randomized quantities of ``model`` into the matching spec elements (same compile order)."""
    for j, joint in enumerate(spec.joints):
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            continue
        dof = model.jnt_dofadr[j]
        joint.damping = [float(model.dof_damping[dof]), 0.0, 0.0]
        joint.frictionloss = float(model.dof_frictionloss[dof])
        joint.armature = float(model.dof_armature[dof])
        joint.stiffness = [float(model.jnt_stiffness[j]), 0.0, 0.0]
    for b, body in enumerate(spec.bodies):
        if b == 0:
            continue
        body.explicitinertial = True
        body.mass = float(model.body_mass[b])
        body.fullinertia = [np.nan] * 6  # the principal form below replaces any full tensor
        body.inertia = model.body_inertia[b].copy()
        body.iquat = model.body_iquat[b].copy()
        body.ipos = model.body_ipos[b].copy()
    for g, geom in enumerate(spec.geoms):
        friction = np.array(geom.friction, dtype=float)
        friction[0] = model.geom_friction[g, 0]
        geom.friction = friction
    spec.option.gravity = model.opt.gravity.copy()


def measure(name: str, resets: int, rebuilds: int) -> dict:
    env = LocoEnv.make(name, domain_randomization_config="default", seed=0)
    env.reset()
    t0 = time.perf_counter()
    for _ in range(resets):
        env.reset()
    in_place = (time.perf_counter() - t0) / resets
    spec = env.build_spec(control=env.control, disable_arms=env.disable_arms)
    spec.option.integrator = env.INTEGRATOR
    spec.option.timestep = env.model.opt.timestep
    if spec.modelfiledir:  # the XML is written elsewhere: point it at the original mesh and texture files
        spec.meshdir = os.path.abspath(os.path.join(spec.modelfiledir, spec.meshdir))
        spec.texturedir = os.path.abspath(os.path.join(spec.modelfiledir, spec.texturedir))
    xml_path = os.path.join(tempfile.mkdtemp(prefix="loco_rand_"), "model.xml")
    times = []
    for _ in range(rebuilds):
        env.reset()
        t0 = time.perf_counter()
        write_into_spec(spec, env.model)
        with open(xml_path, "w") as f:
            f.write(spec.to_xml())
        model = mujoco.MjModel.from_xml_path(xml_path)
        mujoco.MjData(model)
        times.append(time.perf_counter() - t0)
        for field in ("body_mass", "dof_damping", "dof_armature", "geom_friction"):
            if not np.allclose(getattr(model, field), getattr(env.model, field), rtol=1e-5, atol=1e-8):
                raise RuntimeError(f"{name}: the rebuilt model's {field} differs from the randomized one")
        if not np.allclose(model.opt.gravity, env.model.opt.gravity):
            raise RuntimeError(f"{name}: the rebuilt model's gravity differs")
    rebuild = float(np.median(times))
    return {"env": name, "in_place_ms": in_place * 1e3, "xml_ms": rebuild * 1e3, "ratio": rebuild / in_place,
            "params": len(env._randomizer.plan)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", nargs="*", default=DEFAULT_ENVS)
    parser.add_argument("--resets", type=int, default=300)
    parser.add_argument("--rebuilds", type=int, default=5)
    args = parser.parse_args()
    print(f"# mujoco {mujoco.__version__}; in place: mean of {args.resets} resets; XML: median of {args.rebuilds}")
    print("| environment | randomized parameters | reset in place (ms) | re-compile from XML (ms) | ratio |")
    print("|---|---|---|---|---|")
    for name in args.env:
        r = measure(name, args.resets, args.rebuilds)
        print(f"| {name} | {r['params']} | {r['in_place_ms']:.3f} | {r['xml_ms']:.1f} | {r['ratio']:,.0f}x |",
              flush=True)


if __name__ == "__main__":
    main()
