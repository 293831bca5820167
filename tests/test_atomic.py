"""Output files and folders: whole or absent."""

import pytest

from seedtrack.data.atomic import output_folder
from seedtrack.data.errors import DataError


def test_a_failure_removes_the_empty_folders_it_made_and_nothing_else(tmp_path):
    target = tmp_path / "a" / "b" / "c"
    with pytest.raises(KeyboardInterrupt):
        with output_folder(target):
            assert target.is_dir()
            raise KeyboardInterrupt
    assert not (tmp_path / "a").exists() and tmp_path.is_dir()


def test_a_failure_after_the_first_file_keeps_it(tmp_path):
    target = tmp_path / "a" / "b"
    with pytest.raises(RuntimeError):
        with output_folder(target):
            (target / "done.csv").write_text("frame,x,y\n")
            raise RuntimeError("later step failed")
    assert (target / "done.csv").read_text() == "frame,x,y\n"


def test_a_file_in_the_way_is_a_data_error(tmp_path):
    (tmp_path / "taken").write_text("")
    with pytest.raises(DataError, match="exists and is not a folder"):
        with output_folder(tmp_path / "taken"):
            pass


def test_a_failure_removes_the_folder_a_dotted_path_made(tmp_path):
    # x/.. is the parent itself, but making it makes x.
    with pytest.raises(RuntimeError):
        with output_folder(tmp_path / "x" / ".."):
            raise RuntimeError("bad input")
    assert not (tmp_path / "x").exists()
