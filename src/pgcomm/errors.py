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


class SimulationError(DataError):
    """A closed-loop run that left the plant's range.

    ``cause`` is ``"reference"`` (the reference itself leaves the range: the reference file or
    ``[reference]`` settings are at fault) or ``"divergence"`` (the loop went unstable or
    saturated: a setting of the controller, mechanics or plant is at fault). The CLI adds the
    file the cause came from.
    """

    def __init__(self, message: str, cause: str):
        super().__init__(message)
        self.cause = cause
