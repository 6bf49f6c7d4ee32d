"""One module per command; importing this package registers them all on ``cli.app``."""
from . import equations, simulate  # noqa: F401
