"""Native code for the integrators' hot calls: the recursive path's C through the
system compiler, in three parts:

- ``emit``: the C text of a robot's traced programs (``c_source``), its fixed
  part in the ``*.c.in`` templates;
- ``builder``: compile it as a CPython extension, cache the library (hashed,
  checked, owner-only), load it (by the ``named`` module of a text's
  ``signature`` too: a warm run does without the text), or build it in the
  background or quickly during a cold run (``load``, ``build``,
  ``build_in_background``, ``QuickBuild``);
- ``models``: the runtime models, the generated Python's ``RecursiveModel`` and
  the C's ``NativeModel`` (``recursive_model`` picks).
"""
from ..model import NumericModel
from .builder import (FLAGS, QUICK_FLAGS, QuickBuild, build, build_in_background, command,
                      compiler, failed_before, flags, folder, library_path, load, mode,
                      module_name, named, python_include, signature, suffix, unavailable)
from .emit import c_source
from .models import VECTOR_MARK, NativeModel, RecursiveModel, light_source, recursive_model

__all__ = ["FLAGS", "QUICK_FLAGS", "VECTOR_MARK", "NativeModel", "NumericModel", "QuickBuild",
           "RecursiveModel", "build", "build_in_background", "c_source", "command", "compiler",
           "failed_before", "flags", "folder", "library_path", "light_source", "load", "mode",
           "module_name", "named", "python_include", "recursive_model", "signature", "suffix",
           "unavailable"]
