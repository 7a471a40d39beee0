"""Shared set-up of the Python module's tests (run by ctest, which sets
PYTHONPATH to the built module and the variables below; see CMakeLists.txt)."""

import os
import subprocess
import tempfile
import unittest

import colmap_irav4  # noqa: F401  (fails the test early if not importable)

SOURCE_DIR = os.environ.get(
    "COLMAP_IRAV4_SOURCE_DIR",
    os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..")))
BINARY = os.environ.get("COLMAP_IRAV4_BINARY", "")
EXAMPLE_DB = os.path.join(SOURCE_DIR, "tests", "data", "fountain-P11.db")
MODEL_FILES = ("cameras.bin", "images.bin", "points3D.bin")


def require_binary(test):
    if not BINARY or not os.access(BINARY, os.X_OK):
        raise unittest.SkipTest("COLMAP_IRAV4_BINARY (the program) not set")


def run_command(*args):
    """Runs the colmap_irav4 program; returns its completed process."""
    return subprocess.run([BINARY, *args], check=True, capture_output=True,
                          text=True)


def command_model(directory):
    """Maps the bundled example with the command, one thread, seed 0, into
    directory; returns the path of model 0."""
    run_command("mapper", "--database_path", EXAMPLE_DB, "--output_path",
                directory, "--Mapper.num_threads", "1", "--Mapper.seed", "0")
    return os.path.join(directory, "0")


def read_bytes(path):
    with open(path, "rb") as f:
        return f.read()


class TempDirTestCase(unittest.TestCase):
    def setUp(self):
        self._tmp = tempfile.TemporaryDirectory(prefix="colmap_irav4_py_")
        self.tmp = self._tmp.name

    def tearDown(self):
        self._tmp.cleanup()
