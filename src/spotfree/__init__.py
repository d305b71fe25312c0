"""spotfree: ride assistance for two-wheeled mobility robots by spotting-free continuous signal classification."""

from spotfree.errors import InputError, NotBuiltError, SpotfreeError
from spotfree.io.recording import Gap, Recording

__version__ = "0.1.0"

__all__ = ["Gap", "InputError", "NotBuiltError", "Recording", "SpotfreeError", "__version__"]
