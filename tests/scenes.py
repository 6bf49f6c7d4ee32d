"""Small robot files shared by several test modules."""


def cubic_text(q1: float) -> str:
    """A bar on a joint that turns by q1**3: M = 9 q1^4 I_pivot is singular at
    q1 = 0 (the loader accepts it).  The pivot rides on a decoupled carriage
    (s stays 0), so that the message names a state of several coordinates."""
    return f"""\
name: cubic
parameters: {{m: 1.0, L: 1.0, g: 9.81}}
gravity: [0, -g, 0]
coordinates:
  s: {{initial: 0}}
  q1: {{initial: {q1!r}}}
bodies:
  - name: carriage
    joint: {{type: prismatic, axis: [0, 0, 1], displacement: s}}
    mass: 2
  - name: bar
    parent: carriage
    joint: {{type: revolute, axis: [0, 0, 1], displacement: q1**3}}
    mass: m
    com: [L/2, 0, 0]
    inertia: {{iyy: m*L**2/12, izz: m*L**2/12}}
simulation: {{t_end: 3, output_step: 0.01}}
"""


def acrobot_text(law: str) -> str:
    """Two bars, only the elbow actuated (B is 2 x 1), under the control ``law``."""
    return """\
name: acrobot
parameters: {m1: 1.0, m2: 1.5, L1: 1.0, L2: 0.8, g: 9.81}
gravity: [0, -g, 0]
coordinates: {q1: {initial: 0.3}, q2: {initial: -0.2}}
bodies:
  - {name: a, joint: {type: revolute, axis: [0, 0, 1]}, mass: m1, com: [L1/2, 0, 0],
     inertia: {izz: m1*L1**2/12, iyy: m1*L1**2/12}}
  - {name: b, parent: a, joint: {type: revolute, axis: [0, 0, 1], origin: [L1, 0, 0]},
     mass: m2, com: [L2/2, 0, 0], inertia: {izz: m2*L2**2/12, iyy: m2*L2**2/12}}
actuators: {elbow: {joint: b}}
controller:
  gains: {k: 20, c: 3}
  laws:
    elbow: """ + law + "\n"
