"""One module per command, each a plain function whose signature is its options.

``cli`` registers ``COMMANDS`` on its typer app; no command imports the CLI.
"""
from .accuracy import accuracy
from .batch import batch
from .check import check
from .compare import compare
from .equations import equations
from .inverse import inverse
from .simulate import simulate

COMMANDS = (equations, simulate, inverse, compare, accuracy, check, batch)
