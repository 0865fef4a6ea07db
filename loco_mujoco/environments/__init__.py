"""One module per embodiment: which model, which joints, which tasks."""

from loco_mujoco.environments.atlas import Atlas
from loco_mujoco.environments.humanoid_muscle import HumanoidMuscle, HumanoidMuscle4Ages
from loco_mujoco.environments.humanoid_torque import HumanoidTorque, HumanoidTorque4Ages
from loco_mujoco.environments.talos import Talos
from loco_mujoco.environments.unitree_a1 import UnitreeA1
from loco_mujoco.environments.unitree_h1 import UnitreeH1

__all__ = ["Atlas", "HumanoidMuscle", "HumanoidMuscle4Ages", "HumanoidTorque", "HumanoidTorque4Ages", "Talos",
           "UnitreeA1", "UnitreeH1"]
