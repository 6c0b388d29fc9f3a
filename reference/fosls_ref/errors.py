class InputError(Exception):
    """Bad input or usage: the CLI prints one line and exits with status 2."""
