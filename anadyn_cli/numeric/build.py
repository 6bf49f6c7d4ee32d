"""Robot -> ``NumericModel``, through the derivation cache.

``numeric_model`` is the one way in, from a path, a validated ``Robot``, or
(internally) a cache entry.  Derivation and code generation need SymPy; they
are imported only on a cache miss.  On a hit, a path is read and hashed (a
URDF that an earlier run imported is not imported again: ``_robot_text``), and
the stored code and robot info are loaded: no YAML validation, no SymPy; the
generated code's bytecode is kept in the cache too (``cache.compiled``).  Before
the robot's own code is built, a later run is served as the first run was, by
the generic kernel's model that run stored (``_recorded``).
The cache is opt-in (``use_cache``): the command line turns it on, library
calls leave it off unless asked.

Two words say what computes the numbers (every command's JSON records both,
``computation``):

- the *evaluator*: "recursive" runs the Newton-Euler recursions over the
  kinematic tree (generated O(n) code, native C when cached; open trees
  only; no symbolic equations are derived), "closed-form" compiles the
  closed forms M, F, B of a formulation;
- the *formulation* of those closed forms: "kane" or "lagrange" (None when
  the evaluator is recursive).

Unless asked, an open tree runs recursive when no formulation is named;
naming a formulation asks for its closed forms; a closed chain runs the
closed forms of Kane's equations.
"""
from __future__ import annotations

import hashlib
import time
from pathlib import Path

from . import background, cache, constrained
from ..errors import SettingError
from ..model.info import RobotInfo
from .model import NumericModel

#: what runs the numbers (see the module docstring)
EVALUATORS = ("recursive", "closed-form")
#: formulations of the closed forms (``symbolic.formulations.FORMULATIONS``)
FORMULATIONS = ("kane", "lagrange")


def computation(model: NumericModel) -> dict:
    """What computed ``model``'s numbers, as ``check``'s and ``accuracy``'s JSON
    record it: ``{"formulation": "kane" | "lagrange" | None, "evaluator": "recursive" |
    "closed-form", "code": ...}``, the code what ran (as ``simulate``'s JSON says it:
    "generic kernel (...)", "native C (...)", "generated Python (...)")."""
    return {"formulation": model.formulation, "evaluator": model.evaluator,
            "code": getattr(model, "native_note", "generated Python")}


def describe(formulation: str | None, evaluator: str) -> str:
    """What ran, in the words of plot titles and terminal lines: "recursive
    Newton-Euler" or "kane closed forms"."""
    return "recursive Newton-Euler" if evaluator == "recursive" else f"{formulation} closed forms"


def titled(title: str, formulation: str | None, evaluator: str) -> str:
    """A plot title followed by what computed its numbers: ``rr: simulate (recursive
    Newton-Euler)``; the title alone when that is unknown."""
    return f"{title} ({describe(formulation, evaluator)})" if evaluator else title


def _request(formulation: str | None, evaluator: str | None) -> tuple[str | None, str | None]:
    """(formulation, evaluator) asked for, checked; formulation None (evaluator None or
    "recursive"): the robot decides (``numeric_model``)."""
    if evaluator is not None and evaluator not in EVALUATORS:
        raise SettingError("evaluator", f"must be recursive or closed-form, got {evaluator!r}")
    if formulation is not None and formulation not in FORMULATIONS:
        raise SettingError("formulation", f"must be kane or lagrange, got {formulation!r}")
    if evaluator == "recursive" and formulation is not None:
        raise SettingError("evaluator", f"recursive derives no symbolic equations; drop the "
                                        f"formulation ({formulation}) or use closed-form")
    if evaluator == "closed-form" and formulation is None:
        return "kane", evaluator
    return formulation, ("closed-form" if formulation is not None else evaluator)


def _closed_chain(name: str) -> SettingError:
    return SettingError("evaluator", f"recursive needs an open tree; {name} has closed loops "
                                     "(constraints): use closed-form, the default there")


def _cache_key(formulation: str | None) -> str:
    """What the cache entry is filed under: the formulation of the closed forms, or
    "recursive" for the robot's own choice (a closed chain files Kane's closed forms there)."""
    return "recursive" if formulation is None else formulation


def numeric_model(robot, formulation: str | None = None, use_cache: bool = False,
                  timings: dict | None = None, eom=None, jacobian: bool = True,
                  evaluator: str | None = None) -> NumericModel:
    """The numeric model of ``robot`` (a path or a validated ``Robot``).

    ``evaluator`` ("recursive", "closed-form" or None) and ``formulation``
    ("kane", "lagrange" or None) choose what computes the numbers (module
    docstring); the model's ``evaluator`` and ``formulation`` say what does.
    ``eom``: the robot's equations, when the caller has them (their closed
    forms are compiled).  The closed forms carry the analytic Jacobian unless
    ``jacobian`` is off (then never cached: every cached model has it).
    SettingError for a wrong choice, or "recursive" on a closed chain."""
    use_cache = use_cache and jacobian
    with cache.keeping_code(use_cache):             # generated code's bytecode kept too
        return _numeric_model(robot, formulation, use_cache,
                              {} if timings is None else timings, eom, jacobian, evaluator)


def _numeric_model(robot, formulation: str | None, use_cache: bool, timings: dict, eom,
                   jacobian: bool, evaluator: str | None) -> NumericModel:
    formulation, evaluator = ((eom.formulation, "closed-form") if eom is not None
                              else _request(formulation, evaluator))
    if isinstance(robot, (str, Path)):
        return _from_path(robot, formulation, evaluator, use_cache, timings)
    key = _cache_key(formulation)
    if use_cache:
        hit = _cached(robot.digest, key, robot.source, timings, lambda: robot)
        if hit is not None:
            return _checked(hit, evaluator)
        timings["cache"] = "miss"
    if formulation is None:
        if robot.constraints is None:
            return _recursive_model(robot, use_cache, timings)
        if evaluator == "recursive":
            raise _closed_chain(robot.name)
        formulation = "kane"                        # closed chains: Kane's closed forms
    from . import closed_form, trajectory
    from ..symbolic.formulations import derive

    robot.refuse_contacts("closed forms (--formulation, --evaluator closed-form)")
    if eom is None:
        start = time.perf_counter()
        eom = derive(robot, formulation)
        timings["derive"] = time.perf_counter() - start
    start = time.perf_counter()
    code = closed_form.source(robot, eom, jacobian) + trajectory.motion_source(robot)
    if robot.constraints is not None:               # closed chains (numeric.constrained)
        code += constrained.source(robot, eom)
    info = RobotInfo.from_robot(robot)
    model = constrained.model_type(code)(info, code, formulation)
    timings["compile"] = time.perf_counter() - start
    if use_cache:
        cache.store(robot.digest, key, {"code": code, "robot": info.to_dict()})
    return model


def _checked(model: NumericModel, evaluator: str | None) -> NumericModel:
    """A cached ``model``, unless "recursive" was asked for and it holds closed forms."""
    if evaluator == "recursive" and model.evaluator != "recursive":
        raise _closed_chain(model.name)
    return model


def _recursive_model(robot, use_cache: bool, timings: dict) -> NumericModel:
    """Recursive path: generated Python now, the C library when cached (or built
    in the background for the next run; see ``native.mode``).  A cold run
    (``use_cache``, a miss) is served by the generic kernel when it can be
    (``generic.first_run``: the robot's own code is generated, stored and
    compiled in a forked process, ``_own_code``; an earlier build's cost and
    failure are reported first, ``background.report``); otherwise the forward
    dynamics are traced first and compiled alone (``QuickBuild``) while the rest
    is generated: the run switches to that C when it is built."""
    from . import generic, recursive

    start = time.perf_counter()
    pl = recursive.plan(robot)
    if use_cache:
        entry = cache.key(robot.digest, "recursive")
        background.report(entry, robot.name, timings)
        model = generic.first_run(
            robot, pl, RobotInfo.from_robot(robot),
            full=lambda: _generated_model(robot, pl, {}, quick=False, how="off", store=False),
            own_code=lambda: _own_code(robot, pl), entry=entry, timings=timings)
        if model is not None:                       # the plan and tables
            timings["derive"] = time.perf_counter() - start - timings.get("native_compile", 0.0)
            return model
    return _generated_model(robot, pl, timings, quick=use_cache,
                            how=None if use_cache else "off", store=use_cache, start=start)


def _own_code(robot, pl) -> str | None:
    """The robot's own code, generated, its C compiled now and stored in the cache
    (the forked build of a cold run); None, or why its C was not built."""
    from . import native

    model = _generated_model(robot, pl, {}, quick=False, how="wait", store=True)
    return None if isinstance(model, native.NativeModel) else model.native_note


def _generated_model(robot, pl, timings: dict, quick: bool, how: str | None, store: bool,
                     start: float | None = None) -> NumericModel:
    """The robot's own code (generated Python, C by ``how``: ``native.load``) from its
    plan ``pl``; ``quick``: with a ``QuickBuild``; ``store``: into the cache."""
    from . import native, recursive

    start = time.perf_counter() if start is None else start
    forward = recursive.forward(pl)
    quick = native.QuickBuild.start(native.c_source(forward)) if quick else None
    code, c_text = _generated_texts(robot, forward)
    timings["derive"] = time.perf_counter() - start       # the recursive equations
    info = RobotInfo.from_robot(robot)
    start = time.perf_counter()
    model = native.recursive_model(info, code, c_text, None, timings, how=how, quick=quick)
    timings["compile"] = time.perf_counter() - start
    if store:
        _store(robot.digest, info, pl, model.source, code, c_text)
    return model


def _generated_texts(robot, forward) -> tuple[str, str]:
    """The robot's generated Python and C from its traced forward dynamics."""
    from . import native, recursive, trajectory

    generated = recursive.complete(forward)
    code = recursive.module_source(generated) + trajectory.motion_source(robot)
    if "def powers(" not in code:     # check's loads' power, dissipation, springs' energy
        from .closed_form import forces_source
        code += forces_source(robot)
    return code, native.c_source(generated)


def _store(digest: str, info: RobotInfo, pl, light: str, code: str, c_text: str) -> None:
    """File the robot's own code under ``digest``: the entry holds what every warm
    run uses (robot ``info``, the generic kernel's tables for check's integrands, the
    ``light_source`` of the Python, the C's ``signature``, which names its library),
    the side file the whole Python and C texts (``cache.store``), read only when a
    scalar function or a build needs them (``_cached``)."""
    from . import generic, native

    tables, _ = generic.pack(pl)
    cache.store(digest, "recursive", {
        "light": light, "native": native.signature(c_text),
        "robot": info.to_dict(),
        "tables": None if tables is None else tables.to_dict()},
        texts={"code": code, "c": c_text})


#: what a URDF's import is filed under in the derivation cache (``_robot_text``)
URDF_IMPORT = "urdf-import"


def _robot_text(path: str | Path, use_cache: bool) -> tuple[str, str, tuple | None]:
    """(text, display name, to file): ``yamlsource.read_text`` of ``path``.  Under
    the cache, a URDF file that an earlier run imported with the same reading
    options (--fix-base, --inertia, --lock), and ran, is not parsed again: its text
    and import warnings (said again) are read from the cache entry filed under its
    bytes, name and options (``URDF_IMPORT``); else it is imported from the bytes
    that key names, and "to file" is (key, entry), which ``_from_path`` files once
    the robot has run (None: nothing to file).  Only errors name places in the URDF
    (``urdf.place``), and the text of a robot that ran raises none."""
    from ..model import library

    def read_anew(path) -> tuple[str, str]:     # YAML's reader loaded only when it reads
        from ..model.yamlsource import read_text
        return read_text(path)

    resolved = library.resolve(path)
    if not (use_cache and resolved.suffix.lower() == ".urdf" and resolved.is_file()):
        return (*read_anew(resolved), None)
    from ..errors import ModelError, display_name
    from ..model import urdf

    options = urdf.READING.get()
    try:
        raw = urdf.read_urdf(resolved)
    except ModelError:
        raw = None
    if raw is None or options.contacts:             # read_text says why
        return (*read_anew(resolved), None)
    name = display_name(resolved)
    key = hashlib.sha256(repr((name, options)).encode() + b"\0" + raw).hexdigest()
    entry = cache.load(key, URDF_IMPORT)
    filed = None
    if not (isinstance(entry, dict) and isinstance(entry.get("code"), str)
            and isinstance(entry.get("warnings"), list)):
        imported = urdf.import_urdf(raw, name, options.fix_base, options.inertia,
                                    options.lock, options.floating_base)
        entry = {"code": imported.text, "warnings": [str(w) for w in imported.warnings]}
        filed = (key, entry)
    for warning in entry["warnings"]:
        library.announce(f"warning: {warning}", warning=True)
    return entry["code"], name, filed


def robot_of(path: str | Path, use_cache: bool, recorded=None):
    """The validated ``Robot`` of the file ``path`` (a library name too); under the
    cache, a URDF's import that an earlier run filed is read back (``_robot_text``),
    and one read now is filed for the next run.  ``recorded(record)``: whether the
    kernel record (``generic.Record``) that a cold run of the robot left will do
    instead; if so that record is returned, and the robot is neither read nor
    built (under the cache only, with the kernel on and built)."""
    from ..model import robot_from_text

    text, source, filed = _robot_text(path, use_cache)
    if use_cache and recorded is not None and filed is None:
        from . import generic

        record = generic.read(cache.key(_digest(text), "recursive"), source) \
            if generic.enabled() else None
        if record is not None and recorded(record) and generic.kernel() is not None:
            return record
    robot = robot_from_text(text, source)
    if filed is not None:
        cache.store(filed[0], URDF_IMPORT, filed[1])
    return robot


def _digest(text: str) -> str:
    """The digest a robot read from ``text`` has (``Robot.digest``): its cache key."""
    return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()


def _from_path(path: str | Path, formulation: str | None, evaluator: str | None,
               use_cache: bool, timings: dict) -> NumericModel:
    text, source, filed = _robot_text(path, use_cache)
    model = _from_text(text, source, formulation, evaluator, use_cache, timings)
    if filed is not None:                           # imported and ran: filed for next time
        cache.store(filed[0], URDF_IMPORT, filed[1])
    return model


def _from_text(text: str, source: str, formulation: str | None, evaluator: str | None,
               use_cache: bool, timings: dict) -> NumericModel:
    if use_cache:
        digest = _digest(text)
        hit = _cached(digest, _cache_key(formulation), source, timings,
                      lambda: _robot_from_text(text, source))
        if hit is not None:
            return _checked(hit, evaluator)
        if formulation is None:                     # the robot's choice: maybe recursive
            model = _recorded(text, source, digest, timings)
            if model is not None:
                return model
    from ..model import robot_from_text

    start = time.perf_counter()
    robot = robot_from_text(text, source)
    timings["load"] = time.perf_counter() - start
    return numeric_model(robot, formulation, use_cache, timings, evaluator=evaluator)


def _recorded(text: str, source: str, digest: str, timings: dict) -> NumericModel | None:
    """A run that comes before the robot's own code is built (no cache entry yet):
    the generic kernel's model of the first run (``generic.recorded``), the robot
    read and planned only where it is needed, in the background build or for what
    the kernel does not compute; the build's cost and failure reported
    (``background.report``).  None when no cold run left that model."""
    from . import generic

    def planned():
        from ..model import robot_from_text
        from . import recursive

        robot = robot_from_text(text, source)
        return robot, recursive.plan(robot)

    entry = cache.key(digest, "recursive")
    model = generic.recorded(
        entry, source,
        full=lambda: _generated_model(*planned(), {}, quick=False, how="off", store=False),
        own_code=lambda: _own_code(*planned()))
    if model is not None:
        timings["cache"] = "miss"
        background.report(entry, model.name, timings)
    return model


def _cached(digest: str, key: str, source: str, timings: dict, robot) -> NumericModel | None:
    """The cache entry's model (``timings``: the hit, and the cost of the background
    build that stored it, once: ``background.report``); None on a miss, a damaged
    entry or one of an earlier format.  The recursive path's texts are read from the
    entry's side file only when needed (``_StoredTexts``; ``robot()`` gives the
    robot, should they have to be generated again)."""
    entry = cache.load(digest, key)
    if entry is None or "c" in entry:               # "c": the texts inline (format 2)
        return None
    try:
        info = RobotInfo.from_dict(entry["robot"], source)
        if "native" in entry:                       # the recursive path
            from . import generic, native
            texts = _StoredTexts(digest, entry, robot)
            model = native.recursive_model(info, texts.code, texts.c, None,
                                           light=entry["light"],
                                           name=native.named(entry["native"]))
            model.integrands = generic.stored_energies(entry.get("tables"))
        else:
            model = constrained.model_type(entry["code"])(
                info, entry["code"], "kane" if key == "recursive" else key)
    except Exception:           # noqa: BLE001  anything wrong with a stored entry is a miss
        return None
    timings["cache"] = "hit"
    background.report(cache.key(digest, key), model.name, timings)
    return model


def _robot_from_text(text: str, source: str):
    """The validated ``Robot`` of ``text`` (read from ``source``)."""
    from ..model import robot_from_text

    return robot_from_text(text, source)


class _StoredTexts:
    """The generated Python (``code``) and C (``c``) of a recursive cache entry,
    read from its side file when first asked for (``cache.texts``); when that is
    missing, damaged or not the entry's (one warning line), generated again from
    ``robot()`` and filed again."""

    def __init__(self, digest: str, entry: dict, robot):
        self.digest, self.entry, self.robot = digest, entry, robot
        self._texts: dict | None = None

    def _read(self) -> dict:
        if self._texts is None:
            self._texts = cache.texts(self.digest, "recursive", self.entry)
        if self._texts is None or not {"code", "c"} <= self._texts.keys():
            from . import native, recursive

            robot = self.robot()
            pl = recursive.plan(robot)
            code, c_text = _generated_texts(robot, recursive.forward(pl))
            _store(self.digest, RobotInfo.from_robot(robot), pl, native.light_source(code),
                   code, c_text)
            self._texts = {"code": code, "c": c_text}
        return self._texts

    def code(self) -> str:
        return self._read()["code"]

    def c(self) -> str:
        return self._read()["c"]
