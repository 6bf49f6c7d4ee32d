"""The robot and its equations: load a robot file (or a library name, with
parameters overridden), the symbolic equations, the numeric model and its
derivatives, the URDF/MJCF import, the library, and the identification's
parametric model and base parameters."""
from __future__ import annotations

from pathlib import Path
from typing import Mapping

from .common import is_robot, path_of


def load(robot, parameters: Mapping[str, object] | None = None):
    """The validated robot.

    :param robot: a YAML or URDF file's path, a library name, or a ``Robot`` (returned
        as it is).
    :param parameters: values replacing the file's ``parameters`` (numbers, or
        expressions as the file writes them); the file is not written.  A name the
        file does not define is a ``ModelError``.
    :returns: the frozen, validated ``Robot``.
    """
    from ..errors import ModelError
    from ..model import load_robot

    if not is_robot(robot):
        return load_robot(robot, parameters)
    if parameters:
        raise ModelError("parameters apply to a robot file or library name, not to a loaded "
                         "Robot: load(path, parameters=...)")
    return robot


def derive(robot, formulation: str = "kane", symbolic: bool = False):
    """The equations of motion, M(q) ddq = F(t, q, dq) + B(q) tau.

    :param robot: see ``load``.
    :param formulation: "kane" or "lagrange".
    :param symbolic: keep the parameters as symbols (else their values are put in).
    :returns: an ``EquationsOfMotion`` (``M``, ``F``, ``B``, ``q``, ``dq``, ``ddq``,
        ``efforts``: SymPy matrices and symbols).
    """
    from ..symbolic.formulations import derive as derive_equations

    model = load(robot)
    model.refuse_contacts("symbolic equations (derive, equations)")
    return derive_equations(model, formulation, symbolic=symbolic)


def equations(robot, formulation: str = "kane", fmt: str = "text", symbolic: bool = False,
              matrices: bool = False, energies: bool = False,
              kane_terms: bool = False) -> str:
    """What ``anadyn equations`` prints: the equations as readable text or LaTeX.

    :param robot: see ``load``.
    :param formulation: "kane" or "lagrange".
    :param fmt: "text", or "latex" (a document that compiles as it is).
    :param symbolic: keep the parameters as symbols.
    :param matrices: M, F, B instead of one equation per coordinate.
    :param energies: the kinetic and potential energy of each body and in total.
    :param kane_terms: Kane's generalized active and inertia forces per coordinate.
        With none of the three, the equations; with several, each part in that order.
    :returns: the text.
    """
    from .. import progress
    from ..symbolic import render as printout
    from ..symbolic import terms

    model = load(robot)
    equations_asked = matrices or not (energies or kane_terms)
    parts = []
    if equations_asked or kane_terms:
        eom = derive(model, formulation, symbolic)
    if equations_asked:
        parts.append(printout.render(eom, fmt, "matrices" if matrices else "residual"))
        if model.constraints is not None:
            from ..symbolic.formulations.constrained import render_constraints
            parts.append(render_constraints(model, fmt, symbolic))
    if energies:
        with progress.task(f"energies of {model.name}"):
            parts.append(terms.render_energies(terms.energies(model, symbolic), fmt,
                                               model.q, printout.printer))
    if kane_terms:
        with progress.task(f"Kane's terms of {model.name}"):
            parts.append(terms.render_kane_terms(terms.kane_terms(model, eom), fmt,
                                                 printout.printer))
    text = "\n".join(parts)
    if fmt == "latex":
        text = printout.latex_document(text, f"{model.name}: {formulation}, "
                                             f"{'symbolic' if symbolic else 'numeric'} "
                                             "parameters")
    return text


def numeric_model(robot, formulation: str | None = None, evaluator: str | None = None,
                  cache: bool = False):
    """The compiled model the numeric functions run (build it once, run it often).

    :param robot: see ``load``; a ``NumericModel`` is returned as it is.
    :param formulation: "kane" or "lagrange": evaluate the closed forms of these
        equations; None: none named.
    :param evaluator: "recursive" (Newton-Euler recursions, open trees only),
        "closed-form", or None: recursive on an open tree unless a formulation is
        named, Kane's closed forms on a closed chain.
    :param cache: reuse (and fill) the derivation cache.
    :returns: a ``NumericModel``; its ``formulation`` and ``evaluator`` say what runs.
    """
    from ..numeric.build import numeric_model as build
    from ..numeric.model import NumericModel

    if isinstance(robot, NumericModel):
        return robot
    return build(robot if is_robot(robot) else path_of(robot), formulation, use_cache=cache,
                 evaluator=evaluator)


def derivatives(robot, native: bool = True, parameters=()):
    """The open-loop derivatives of the forward and inverse dynamics (recursive
    path, open trees): ``forward_derivatives(t, q, dq, tau)``,
    ``inverse_derivatives(t, q, dq, ddq)``, ``mass_matrix_inverse(q)``, and with
    ``parameters`` ``forward_parameter_derivatives(t, q, dq, tau)`` (d(ddq)/dp, (n, k)),
    ``inverse_parameter_derivatives(t, q, dq, ddq)`` (d(ID)/dp, (n, k)) and
    ``closed_loop_parameter_derivatives(t, q, dq)`` (d(ddq)/dp under the control laws),
    at one state or at N states (rows); shapes in ``anadyn_cli.numeric.derivatives``.

    :param robot: see ``load``.
    :param native: run C (compiled now on first use, then cached; the generated
        Python, vectorized by NumPy, without a compiler); False: the Python.
    :param parameters: names of the robot file's parameters (a mass, a length, an
        inertia, g, ...) or gains to differentiate with respect to, in the columns'
        order.
    :returns: a ``Derivatives`` (``native`` is the C extension or None, ``note``
        says why).
    """
    from ..numeric.derivatives import derivatives as build

    return build(load(robot), native, parameters)


def import_urdf(urdf, out: str | Path | None = None, fix_base: bool = False,
                inertia: str = "refuse", lock: Mapping[str, float | str] | None = None):
    """A URDF robot as an anadyn robot file (``anadyn import``).

    :param urdf: a URDF file's path, or the name of a library robot.
    :param out: the robot file to write (YAML with comments); None: write nothing.
    :param fix_base: weld a floating or planar root joint to the world.
    :param inertia: physically impossible inertias: "refuse", "repair" or "accept".
    :param lock: joints held at a value, {joint: number or text such as "pi/4"}: a
        reduced robot, as Pinocchio's ``buildReducedModel`` makes it.
    :returns: an ``Imported``: ``text`` (the robot file), ``data``, ``warnings``; the
        text is validated as a robot before it is returned.
    """
    from ..errors import ModelError
    from ..files import write_text
    from ..model import library, robot_from_text
    from ..model.urdf import import_file

    path = library.resolve(urdf)
    if path.suffix.lower() != ".urdf":
        raise ModelError("not a URDF file (expected a .urdf file name)", source=str(path))
    imported = import_file(path, fix_base=fix_base, inertia=inertia, lock=lock or ())
    robot_from_text(imported.text, f"{path} (imported)")         # what is written loads
    if out is not None:
        write_text(Path(out), imported.text)
    return imported


def robots():
    """The robot library (``anadyn robots``).

    :returns: one ``library.Entry`` per robot: ``name``, ``path``, ``dof``, ``joints``,
        ``description``.
    """
    from ..model import library

    return library.listing()


def parametric_model(robot):
    """The robot's dynamics linear in its parameters, Q = Y(q, dq, ddq) pi (open trees;
    each joint displacement linear in the coordinates).

    :param robot: see ``load``.
    :returns: a ``ParametricModel``: ``regressor(q, dq, ddq)`` (N, n, p; the generated
        function, native C over the N states, compiled on first use and cached),
        ``actuator_regressor`` (N, m, p), ``names`` (10 per body: m, m*cx, m*cy, m*cz,
        Ixx, Ixy, Iyy, Ixz, Iyz, Izz about the body origin in body axes; per moving
        joint Ia, Fv, Fc), ``nominal`` (the file's pi).
    """
    from ..studies.identification.regressor import parametric_model as build

    return build(load(robot))


def base_parameters(robot, exact: bool | None = None, states: int = 60, seed: int = 0):
    """The identifiable combinations of the parameters (``equations --base-parameters``).

    :param robot: see ``load``.
    :param exact: also solve the coefficients exactly from Kane's equations [robots of up
        to three coordinates].
    :param states: random states of the rank-revealing QR.
    :param seed: their seed.
    :returns: a ``BaseParameters``: ``rank``, ``K`` (base = K pi), ``expressions()``,
        ``exact`` (rational coefficients or None).
    """
    from ..studies.identification.base import base_parameters as compute

    return compute(parametric_model(robot), states, seed, exact)
