"""Contact between bodies and ground planes (the robot file's ``contacts`` section).

Two contact models (``Contacts.model``).  In both each contact is a sphere
(``radius`` > 0) or a point (radius 0) fixed on a body, pressed against a ground
plane n . x = height (n a unit normal in world axes, the solid on the side -n), or
against a sphere on another body (``Partner``).  The file's capsules and boxes are
made of these (``loader.contacts``): against a ground, a capsule is its two end
spheres and a box its eight corners as points (the deepest point of either lies
among them); against a sphere, one contact whose centre is the point of a segment
(a capsule) or of a solid box nearest the partner's centre (``Contact.spans``).
With the penetration d = radius - (n . c - height) (c the sphere's centre in world
axes) and its rate d', the ground pushes at the sphere's lowest point c - radius n
with

    normal:   f_n = max(0, d)^p * max(0, k + c_d d')          (Hunt-Crossley; >= 0)
    friction: f_t = -mu f_n tanh(|v_t| / v_s) v_t / |v_t|      (regularized Coulomb)

v_t the velocity of the body's material point at the contact, less its normal part.
That is the *compliant* model.  The *rigid* one (``numeric.impacts``) makes each
contact a unilateral constraint with impacts (Newton's restitution, Coulomb friction
with one coefficient); of the law it uses only ``friction`` and ``restitution``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:               # SymPy-valued, but not imported: a cached run needs none
    import sympy as sp

    Vector = tuple[sp.Expr, sp.Expr, sp.Expr]

#: the contact models (module docstring)
CONTACT_MODELS = ("compliant", "rigid")
#: defaults of the compliant law: Hertz exponent 3/2, friction smoothed over 0.01 m/s
#: (the joints' friction_velocity default)
DEFAULT_EXPONENT = 1.5
DEFAULT_FRICTION_VELOCITY = 0.01


@dataclass(frozen=True)
class Ground:
    """The plane n . x = height in world axes (n unit; the solid lies on the side -n)."""
    normal: Vector
    height: sp.Expr


@dataclass(frozen=True)
class ContactLaw:
    """Hunt-Crossley normal law f_n = max(0, d)^exponent max(0, stiffness + damping d')
    (stiffness N/m^exponent, damping s/m: c_d = 1.5 alpha k for Hunt and Crossley's
    alpha) and regularized Coulomb friction mu f_n tanh(|v_t| / friction_velocity)
    (one coefficient: static and kinetic equal); ``restitution`` e in [0, 1], the rigid
    model's Newton coefficient (normal speed after an impact = -e times before), and its
    ``static_friction`` mu_s >= mu (default mu): a contact sticks while |f_t| <= mu_s
    f_n and slides against f_t = mu f_n (``friction``, kinetic there)."""
    stiffness: sp.Expr
    damping: sp.Expr
    exponent: sp.Expr
    friction: sp.Expr
    friction_velocity: sp.Expr
    restitution: sp.Expr
    static_friction: sp.Expr          # the rigid model's: sticking holds while |f_t| <= it f_n


@dataclass(frozen=True)
class Partner:
    """A sphere of ``radius`` (> 0) centred at ``point`` (body axes, m) on ``body``."""
    body: str
    point: Vector
    radius: sp.Expr


@dataclass(frozen=True)
class Contact:
    """A sphere of ``radius`` (0: a point) centred at ``point`` (body axes, m) on
    ``body``, against ``ground`` or, when given, the sphere ``partner`` on another
    body (then ``ground`` is None), under ``law``.  Between two spheres,
    d = radius + partner radius - |c - c_partner|, n from the partner's centre to this
    one's, and the force acts at the middle of the overlap on both bodies.

    ``spans`` (against a partner only) are vectors e_k (body axes, m, mutually
    orthogonal) that sweep the centre over point + sum s_k e_k, |s_k| <= 1: one span
    (half a capsule's segment) or three (a box's half-extents along its axes); the
    centre used is the swept point nearest the partner's centre, each s_k the clamped
    projection (e_k . (c_partner - point)) / |e_k|^2."""
    name: str
    body: str
    point: Vector
    radius: sp.Expr
    ground: Ground | None
    law: ContactLaw
    partner: Partner | None = None
    spans: tuple[Vector, ...] = ()


@dataclass(frozen=True)
class Contacts:
    """The scene's contact model (``CONTACT_MODELS``) and its contacts, in file order."""
    model: str
    items: tuple[Contact, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.items)
