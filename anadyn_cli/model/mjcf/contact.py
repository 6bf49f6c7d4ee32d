"""MuJoCo's contact geoms as anadyn's compliant contacts (``importer._Importer.contacts``).

Which pairs: a sphere, capsule or box geom on a moving body against a ``plane`` geom of
the world (the world body or a body fixed to it), when MuJoCo would collide them:
(contype1 & conaffinity2) or (contype2 & conaffinity1) (``collides``; MuJoCo's
parent-child filter spares the world, and two geoms of the world never collide).

The law: MuJoCo's soft contact (solref = (timeconst, dampratio), solimp = (dmin, dmax,
width, midpoint, power)) is a spring-damper in acceleration space whose impedance d lets
it sink, under an acceleration g along the normal, to the depth r solving

    r = g (1 - d(r)) dmax^2 timeconst^2 dampratio^2 / d(r)^2        (``resting_depth``)

whatever the mass (0.367 mm at the defaults (0.02, 1), (0.9, 0.95, 0.001, 0.5, 2);
checked against MuJoCo in tests/test_contact_shapes.py).  anadyn's Hunt-Crossley law
(exponent 3/2) is given the stiffness k = W / r^1.5 that sinks one contact carrying the
model's whole weight W = M g to the same depth, and the damping c_d that makes that
resting contact's linearized oscillator damped at MuJoCo's ratio:
c_d r^1.5 = 2 dampratio sqrt(1.5 W M / r) (``law``).  Lighter-loaded contacts sink
less, (share)^(2/3) of r; the time constant at rest is sqrt(r / (1.5 g)) (5 ms at the
defaults) where MuJoCo's is timeconst (20 ms): the penetrations agree, the transients
do not.  Friction: friction[0], the larger of the two geoms' (MuJoCo's default
combination).  The margin raises the plane by it (MuJoCo measures the penetration from
the margin).
"""
from __future__ import annotations

import math

#: MuJoCo's defaults
SOLREF = (0.02, 1.0)
SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)
#: the range MuJoCo clamps the impedance d to (mjMINIMP, mjMAXIMP)
IMPEDANCE = (0.0001, 0.9999)
#: the MJCF geom types imported as contacts (shapes of ``model.loader.contacts``)
CONTACT_GEOMS = ("sphere", "capsule", "box")


def collides(a: tuple[int, int], b: tuple[int, int]) -> bool:
    """MuJoCo's bit test of two geoms' (contype, conaffinity)."""
    return bool(a[0] & b[1]) or bool(b[0] & a[1])


def impedance(depth: float, solimp) -> float:
    """d(r) of MuJoCo's solimp at the penetration ``depth`` (>= 0)."""
    dmin, dmax, width, midpoint, power = solimp
    x = min(depth / width, 1.0) if width > 0 else 1.0
    if x <= midpoint:
        y = x ** power / midpoint ** (power - 1) if midpoint > 0 else 1.0
    else:
        y = 1 - (1 - x) ** power / (1 - midpoint) ** (power - 1) if midpoint < 1 else 0.0
    return min(max(dmin + y * (dmax - dmin), IMPEDANCE[0]), IMPEDANCE[1])


def resting_depth(solref, solimp, g: float) -> float:
    """MuJoCo's penetration at rest under the acceleration g (module docstring): the
    root of r - sink(r), sink decreasing (d grows with r), by bisection between 0 and
    sink(0)."""
    timeconst, dampratio = solref

    def sink(depth: float) -> float:
        d = impedance(depth, solimp)
        return g * (1 - d) * solimp[1] ** 2 * timeconst ** 2 * dampratio ** 2 / d ** 2

    low, high = 0.0, sink(0.0)
    for _ in range(200):
        middle = (low + high) / 2
        low, high = (middle, high) if sink(middle) > middle else (low, middle)
    return (low + high) / 2


def law(mass: float, g: float, solref, solimp) -> tuple[float, float, float]:
    """(stiffness k, N/m^1.5; damping c_d, N s/m^2.5; resting depth, m) for a model of
    ``mass`` under gravity g (module docstring)."""
    depth = resting_depth(solref, solimp, g)
    weight = mass * g
    stiffness = weight / depth ** 1.5
    damping = 2 * solref[1] * math.sqrt(1.5 * weight * mass / depth) / depth ** 1.5
    return stiffness, damping, depth
