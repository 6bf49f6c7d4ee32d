"""anadyn: analytical dynamics of robot arms (the import name of ``anadyn_cli``).

Every command is a function here (``anadyn_cli.api``); ``import_urdf`` is
``anadyn import`` (``import`` is a Python keyword).
"""
from anadyn_cli import AnadynError, CheckFailed, ModelError, NumericalError, __version__
from anadyn_cli.api import (accuracy, animate, batch, check, compare, derivatives, derive,
                            equations, export, import_urdf, inverse, linearize, load, numeric_model, optimize,
                            robots, show, simulate, sweep, view)
from anadyn_cli.api import base_parameters, excite, identify, parametric_model  # noqa: E402
from anadyn_cli.errors import SettingError

__all__ = ["load", "derive", "numeric_model", "derivatives", "equations", "simulate", "inverse",
           "check", "compare", "accuracy", "export", "linearize", "optimize", "sweep", "batch", "show",
           "animate", "view", "import_urdf", "robots",
           "parametric_model", "base_parameters", "identify", "excite",
           "AnadynError", "ModelError", "SettingError", "CheckFailed", "NumericalError",
           "__version__"]
