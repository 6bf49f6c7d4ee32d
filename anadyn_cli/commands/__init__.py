"""One module per command; importing this package registers them all on ``cli.app``."""
from . import accuracy, batch, check, compare, equations, inverse, simulate  # noqa: F401
