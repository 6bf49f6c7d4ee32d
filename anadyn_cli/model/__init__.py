"""Robot descriptions: YAML -> frozen, validated dataclasses.

Names load on first use: ``model.yamlsource`` and ``model.yamlschema`` must stay importable without
SymPy (the cached fast path reads files through it).
"""
from importlib import import_module

_LAZY = {"load_robot": ".loader", "robot_from_text": ".loader", "Robot": ".robot",
         "Body": ".robot", "Joint": ".robot", "Coordinate": ".robot", "Actuator": ".robot",
         "Controller": ".robot", "Trajectory": ".robot", "Simulation": ".robot"}
__all__ = list(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module 'anadyn_cli.model' has no attribute {name!r}")
