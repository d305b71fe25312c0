"""The spotfree exception family.

Every error a user can cause derives from :class:`SpotfreeError`; its message names the file, the field and the
fix, in one line, so the command line can print it as is and exit with status 2.
"""


class SpotfreeError(Exception):
    """Root of every error spotfree raises on purpose."""


class InputError(SpotfreeError, ValueError):
    """Bad input: a file, a column, a cell or a parameter that cannot be used as given."""


class NotBuiltError(SpotfreeError):
    """A command of the contract whose implementation has not landed yet."""
