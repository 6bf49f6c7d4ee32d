"""anadyn: analytical dynamics of robot arms.

    robot = load_robot("robots/rr.yaml")
    eom = derive(robot, "kane")        # or "lagrange"
    eom.M, eom.F, eom.B                # M(q) ddq = F(q, dq) + B(q) tau
"""
from .eom import EquationsOfMotion
from .errors import AnadynError, CheckFailed, ModelError, NumericalError
from .formulations import derive
from .model import load_robot, robot_from_text

__version__ = "0.1.0"
__all__ = ["load_robot", "robot_from_text", "derive", "EquationsOfMotion", "AnadynError",
           "ModelError", "CheckFailed", "NumericalError", "__version__"]
