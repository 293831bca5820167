"""The one exception type for input a user gave us that we cannot use."""


class DataError(Exception):
    """Bad input or output file: the message names the file and the problem in one line."""

    def __init__(self, path, problem: str) -> None:
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem
