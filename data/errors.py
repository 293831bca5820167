"""The one exception type for input a user gave us that we cannot use."""

from pathlib import Path


class DataError(Exception):
    """Bad input or output file: the message names the file and the problem in one line."""

    def __init__(self, path, problem: str) -> None:
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem

    def __reduce__(self):
        # Rebuilt from its two parts, so that it survives the trip back from a worker process.
        return type(self), (self.path, self.problem)

    @classmethod
    def not_utf8(cls, path, error: UnicodeDecodeError) -> "DataError":
        """The error for a text file in another encoding (Excel's plain "CSV" is cp1252)."""
        return cls(path, f"is not UTF-8 text (byte {error.start} of the file); save it as UTF-8 ('CSV UTF-8' in Excel)")


class DataWarning(UserWarning):
    """Input the program can use but that a user should hear about (the command prints it as one line)."""


def warn(path, problem: str) -> None:
    """Tell the user about ``path`` without stopping: a :class:`DataWarning` naming the file."""
    import warnings

    warnings.warn(DataWarning(f"{path}: {problem}"), stacklevel=2)


def check_file(path) -> Path:
    """``path`` as a Path, if it names an existing file.

    Raises
    ------
    DataError
        "no such file", "is a folder" when it names one (a folder given where a file belongs), or
        "not a regular file" for a pipe such as bash's ``<(command)``, which cannot be read twice.
    """

    path = Path(path)
    if path.is_dir():
        raise DataError(path, "is a folder; give a file")
    if path.exists() and not path.is_file():
        raise DataError(path, "not a regular file (a pipe or a device); save it to a file first")
    if not path.is_file():
        raise DataError(path, "no such file")
    return path
