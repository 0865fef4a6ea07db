"""loco_mujoco: imitation-learning benchmark for legged locomotion on MuJoCo.

    import loco_mujoco as lm
    env = lm.LocoEnv.make("UnitreeH1.walk")      # Mushroom-RL environment
    lm.list_tasks()                              # every valid task name
    gymnasium.make("LocoMujoco", env_name="UnitreeH1.walk")
"""

from loco_mujoco import _compat  # noqa: F401  (must run before mushroom_rl is imported anywhere)
from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.core.task_names import list_tasks, parse_task_name
from loco_mujoco.environments import Talos, UnitreeA1, UnitreeH1
from loco_mujoco.gymnasium_env import register_gymnasium

register_gymnasium()

__version__ = "0.1.0"
__all__ = ["LocoEnv", "Task", "Talos", "UnitreeA1", "UnitreeH1", "list_tasks", "parse_task_name", "__version__"]
