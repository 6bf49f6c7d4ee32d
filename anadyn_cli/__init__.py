"""anadyn: analytical dynamics of robot arms.

    robot = load_robot("robots/rr.yaml")
    eom = derive(robot, "kane")        # or "lagrange"
    eom.M, eom.F, eom.B                # M(q) ddq = F(q, dq) + B(q) tau

Names are imported on first use, so that ``import anadyn_cli`` (and the
command line) stays fast and SymPy loads only when something needs it.
"""
from importlib import import_module

from .errors import AnadynError, CheckFailed, ModelError, NumericalError

__version__ = "0.1.0"

_LAZY = {"load_robot": ".model", "robot_from_text": ".model", "derive": ".symbolic.formulations",
         "EquationsOfMotion": ".symbolic.eom"}
__all__ = [*_LAZY, "AnadynError", "ModelError", "CheckFailed", "NumericalError", "__version__"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'anadyn_cli' has no attribute {name!r}")
