"""A correction does not depend on buffering (issue 17, item 16).

``encal correct`` evaluates whatever block of lines a read returns. Matrix products (BLAS) sum a row
in an order that depends on where the row falls in the block, and the spectral model switched
method with the number of angles, so a line's answer changed in its last bit with the pipe's timing.
Every model kind must give bit-identical predictions for an angle alone and among others.
"""

import io

import numpy as np
import pytest

import encal
from encal.deploy import Compensator
from encal.deploy.stream import correct_stream

GRID = np.arange(0.0, 360.0, 2.0)
PROFILE = (2.0 * np.sin(np.radians(GRID) + 0.3) + 0.6 * np.cos(np.radians(2 * GRID))
           + 0.2 * np.sin(np.radians(16 * GRID)) + 0.05 * np.cos(np.radians(37 * GRID)))
CAL = encal.Calibration(GRID, GRID + PROFILE / 60.0)

KINDS = {
    "fourier": dict(method="fourier"),
    "lut-cubic": dict(method="lut"),
    "lut-linear": dict(method="lut", interpolation="linear"),
    "ann-periodic": dict(method="ann", hidden=12, epochs=30, rng=0),
    "ann-raw": dict(method="ann", hidden=12, epochs=30, encoding="raw", rng=0),
    "hybrid": dict(method="hybrid", hidden=4, epochs=20, rng=0),
    "spectral": dict(method="spectral"),
}


@pytest.fixture(scope="module", params=sorted(KINDS))
def model(request):
    options = dict(KINDS[request.param])
    return encal.fit(CAL, options.pop("method"), **options)


ANGLES = np.random.default_rng(3).uniform(-720.0, 720.0, 1500)


def test_an_angle_alone_and_in_a_block_give_the_same_bits(model):
    block = model.predict(ANGLES)
    alone = np.array([model.predict(angle) for angle in ANGLES[:200]])
    np.testing.assert_array_equal(block[:200], alone)
    for start in (1, 3, 7, 13):
        np.testing.assert_array_equal(model.predict(ANGLES[start:]), block[start:])


class _Chunks(io.RawIOBase):
    """A source whose reads return pieces of the given sizes, as a pipe does."""

    def __init__(self, data, sizes):
        self.data, self.sizes, self.at = data, list(sizes), 0

    def readable(self):
        return True

    def read1(self, limit=-1):
        size = self.sizes.pop(0) if self.sizes else len(self.data)
        piece = self.data[self.at:self.at + min(size, limit if limit > 0 else size)]
        self.at += len(piece)
        return piece

    read = read1


def test_stream_answers_do_not_depend_on_how_the_input_arrives(model):
    data = "".join(f"{angle!r}\n" for angle in ANGLES.tolist()).encode()
    answers = []
    for seed in range(3):
        sizes = np.random.default_rng(seed).integers(1, 4000, 200).tolist()
        sink = io.BytesIO()
        correct_stream(Compensator(model), _Chunks(data, sizes), sink)
        answers.append(sink.getvalue())
    whole = io.BytesIO()
    correct_stream(Compensator(model), io.BytesIO(data), whole)
    assert answers[0] == answers[1] == answers[2] == whole.getvalue()
