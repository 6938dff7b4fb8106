"""User-facing errors: one clear line, exit code 2 in the CLI."""


class PgcommError(Exception):
    """A user error (bad file, bad value, bad option).

    The CLI prints ``str(err)`` as one line prefixed with ``pgcomm: error:`` and
    exits with code 2, without a traceback. Messages name the file, column, row
    or value concerned and say what was expected.
    """


class DataError(PgcommError):
    """Input data (logs, force maps, references) that cannot be used."""


class ConfigError(PgcommError):
    """A motor/experiment TOML or command-line setting that is invalid."""


class ExcitationError(DataError):
    """Data that does not persistently excite the model (paper, Remark on excitation)."""
