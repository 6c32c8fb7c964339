"""Where the tests' files are, whatever the depth of the test that asks.

Every path a test needs outside its own file comes from here, so that moving a test to another folder of
``tests/`` changes none of them: the repository and its folders, the model files of ``tests/data/``, and
``shared/`` beside the repository (the firmwares' own code and the real calibrations, which are test
fixtures and may be absent: the tests that need them skip with the reason).
"""

from pathlib import Path

#: ``tests/``, the folder of this file.
TESTS = Path(__file__).resolve().parent
#: The repository (the checkout), above ``tests/``.
REPO = TESTS.parent
#: The source tree to put on ``PYTHONPATH`` of a child process.
SRC = REPO / "src"
#: The example calibrations of the README.
EXAMPLES = REPO / "examples"
README = REPO / "README.md"
#: Model files of every format version and their expected values (``tests/data/make_model_files.py``).
DATA = TESTS / "data"
#: ``shared/`` beside the repository: test fixtures that are not the project's.
SHARED = REPO.parent / "shared"
#: The firmwares' own source (read-only; never copied into the project).
FIRMWARE = SHARED / "firmware"
#: Real AS5047D calibrations taken on a Mechaduino.
REAL_MECHADUINO = SHARED / "data" / "real" / "mechaduino"
