"""One module per command, each a plain function whose signature is its options.

``cli`` registers ``COMMANDS`` on its typer app; no command imports the CLI.
"""
from .accuracy import accuracy
from .animate import animate
from .batch import batch
from .check import check
from .compare import compare
from .equations import equations
from .import_urdf import import_urdf
from .inverse import inverse
from .robots import robots
from .show import show
from .simulate import simulate

COMMANDS = (equations, simulate, inverse, compare, accuracy, check, batch, import_urdf, robots,
            show, animate)
from .sweep import sweep; COMMANDS = (*COMMANDS, sweep)  # noqa: E402, E702  (one line: merges cleanly)
from .export import export; from .linearize import linearize; COMMANDS = (*COMMANDS, export, linearize)  # noqa: E402, E702
from .view import view; COMMANDS = (*COMMANDS, view)  # noqa: E402, E702
from .optimize import optimize; COMMANDS = (*COMMANDS, optimize)  # noqa: E402, E702
from .identify import identify; from .excite import excite; COMMANDS = (*COMMANDS, identify, excite)  # noqa: E402, E702
