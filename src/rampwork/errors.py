"""Errors raised for bad input before any work starts."""


class ConfigError(ValueError):
    """Bad input: says which parameter, what value, and what is allowed.

    The CLI prints the message on one line and exits with status 2.
    """

    def __init__(self, where: str, problem: str):
        self.where = where
        self.problem = problem
        super().__init__(f"{where}: {problem}")

    def __reduce__(self):
        # so that an error raised on a Dask worker reaches the client intact
        return type(self), (self.where, self.problem)
