"""Expected failures.

Anything raised as a :class:`WhiskercalError` is a condition a user can cause or fix (no device,
bad file, out-of-range input, device alarm). The CLI prints it as one line on stderr and exits
non-zero; everything else is a bug and keeps its traceback.
"""


class WhiskercalError(Exception):
    """A failure the user can act on; its message is the whole story."""

    exit_code = 1


class UsageError(WhiskercalError):
    """Bad input: an option, a file, a value out of range."""

    exit_code = 2


class DeviceError(WhiskercalError):
    """A device is missing, unplugged, in alarm, or speaks the wrong protocol."""

    exit_code = 3


class ArtifactError(WhiskercalError):
    """A dataset or artifact file is missing, corrupt, or of an unknown schema version."""

    exit_code = 4
