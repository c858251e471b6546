"""The command line's exception: a user error that ends ``adaptid`` with exit code 2."""

__all__ = ["CLIError"]


class CLIError(Exception):
    """A problem with the user's input (file, column, option): exit code 2.

    The message is one line that names the file, column or option at fault;
    the command line prints it as ``adaptid: error: <message>`` on stderr,
    without a traceback unless ``--debug`` is given.
    """

    exit_code = 2

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))
