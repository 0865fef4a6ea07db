"""Tracking figures of the quadruped controller: ``python -m loco_mujoco.controllers [--seconds 60] [--control pd]``.

For each commanded forward speed: the mean forward speed after the ramp-up, its error, the sideways drift and
heading change, and whether the robot fell; then how long turning to a few goal headings takes.
"""

from __future__ import annotations

import argparse
import math
import time

from loco_mujoco.controllers.datasets import RAMP_UP_S, controller_env, rollout, tracking
from loco_mujoco.controllers.quadruped import QuadrupedController, wrap_angle, yaw_of


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="UnitreeA1.simple")
    parser.add_argument("--control", default="pd", choices=("pd", "torque"))
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--speeds", default="0.2,0.4,0.6,0.8,1.0,1.2", help="forward speeds (m/s), comma-separated")
    args = parser.parse_args(argv)

    env = controller_env(args.task, args.control)
    controller = QuadrupedController(env)
    print(f"{args.task}, control={args.control}, {args.seconds:.0f} s per speed, figures after {RAMP_UP_S:.0f} s")
    print(f"{'command':>8} {'achieved':>9} {'error':>7} {'lateral':>8} {'heading':>8} {'fell':>5} {'wall':>6}")
    for speed in (float(v) for v in args.speeds.split(",")):
        start = time.perf_counter()
        fig = tracking(rollout(env, controller, args.seconds, speed), env.dt)
        print(f"{speed:8.2f} {fig['achieved_forward_mps']:9.3f} {100 * fig['relative_error']:6.2f}% "
              f"{fig['achieved_lateral_mps']:8.3f} {fig['heading_change_rad']:8.3f} {fig['fell']!s:>5} "
              f"{time.perf_counter() - start:5.1f}s")

    print("turning at 0.5 m/s to a goal heading: seconds until within 0.05 rad")
    for goal in (math.pi / 2, -math.pi / 2, 0.99 * math.pi):
        env.reset()
        controller.reset()
        controller.command(0.5, heading=goal)
        reached = None
        for step in range(int(10.0 / env.dt)):
            _, _, fell, _ = env.step(controller())
            yaw = yaw_of(env.data.qpos[3:7])
            if reached is None and abs(wrap_angle(goal - yaw)) < 0.05:
                reached = (step + 1) * env.dt
            if fell:
                break
        print(f"  goal {goal:+.2f} rad: {'fell' if fell else f'{reached:.2f} s' if reached else 'not reached'}")
    env.stop()


if __name__ == "__main__":
    main()
