"""User-facing errors of the host tools."""


class MfnsError(Exception):
    """A user-facing error: `mfns` prints it as one line and exits with status 2."""
