"""anadyn: analytical dynamics of robot arms (the import name of ``anadyn_cli``).

See ``anadyn_cli.api`` for the functions and the README's "Python API".
"""
from anadyn_cli import AnadynError, CheckFailed, ModelError, NumericalError, __version__
from anadyn_cli.api import check, compare, derive, inverse, load, numeric_model, simulate

__all__ = ["load", "derive", "numeric_model", "simulate", "inverse", "check", "compare",
           "AnadynError", "ModelError", "CheckFailed", "NumericalError", "__version__"]
