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


# -- task edge5: a direction column corrects each reading with its own direction -------------------------------

HYSTERESIS = 1.5  # arc-minutes: a forward reading is 0.75 above the profile, a reverse one 0.75 below


def _bidirectional_truth():
    """A directional model of a known profile and hysteresis, and readings of both directions with their truth."""
    reference = np.r_[GRID, GRID[::-1]]
    direction = np.r_[np.ones(GRID.size), -np.ones(GRID.size)]
    exact = (2.0 * np.sin(np.radians(reference) + 0.3) + 0.6 * np.cos(np.radians(2 * reference))
             + direction * HYSTERESIS / 2.0)
    model = encal.fit(encal.Calibration(reference, reference + exact / 60.0, direction=direction), "fourier",
                      orders=[0, 1, 2])
    truth = np.arange(0.5, 360.0, 7.0)
    sign = np.where(np.arange(truth.size) % 3 == 0, -1, 1)
    reading = truth + (2.0 * np.sin(np.radians(truth) + 0.3) + 0.6 * np.cos(np.radians(2 * truth))
                       + sign * HYSTERESIS / 2.0) / 60.0
    return model, truth, sign, reading


@pytest.mark.parametrize("cells", [("+1", "-1"), ("cw", "CCW"), ('"1"', '"-1"'), ("1.0", "-1.000000e+00")])
def test_a_direction_column_corrects_each_reading_with_its_own_direction(cells):
    """It was ignored: every reading got the mean of the two directions, 0.75 arcmin (half the hysteresis) off
    the truth, with exit 0."""
    model, truth, sign, reading = _bidirectional_truth()
    assert model.kind == "directional"
    rows = "".join(f"{i},{r!r},{cells[0] if s > 0 else cells[1]}\n"
                   for i, (r, s) in enumerate(zip(reading.tolist(), sign)))
    data = ("t,encoder_deg,direction\n" + rows).encode()
    for sizes in ([len(data)], np.random.default_rng(1).integers(1, 40, 400).tolist()):
        sink = io.BytesIO()
        correct_stream(Compensator(model), _Chunks(data, sizes), sink)
        corrected = np.array(sink.getvalue().split(), dtype=float)
        gap = ((corrected - truth + 180.0) % 360.0 - 180.0) * 60.0
        assert np.max(np.abs(gap)) < 2e-3  # measured 6.3e-4 (3 orders of a profile of the reference); was 0.75
    mean = io.BytesIO()  # without the column: the mean of both, as documented
    plain = b"encoder_deg\n" + "".join(f"{r!r}\n" for r in reading.tolist()).encode()
    correct_stream(Compensator(model), io.BytesIO(plain), mean)
    off = np.max(np.abs(np.array(mean.getvalue().split(), dtype=float) - truth)) * 60.0
    assert off == pytest.approx(HYSTERESIS / 2.0, abs=3e-3)


@pytest.mark.parametrize("cell", ["\u00a01", "-1\u00a0", "\u3000cw"])
def test_a_direction_cell_with_a_blank_other_than_a_space_or_tab_is_a_malformed_line(cell):
    # fuzz6: taken as the direction, where an angle's cell with the same blank is refused
    model, *_ = _bidirectional_truth()
    data = f"encoder_deg,direction\n10.0, -1\n11.0,{cell}\n".encode()
    sink = io.BytesIO()
    correct_stream(Compensator(model), io.BytesIO(data), sink, skip_bad=True)
    assert sink.getvalue().split()[1] == b"nan"


def test_a_direction_column_and_a_direction_option_are_refused_and_a_bad_direction_is_named():
    from encal._core.errors import InputError

    model, *_ = _bidirectional_truth()
    data = b"encoder_deg,direction\n10.0,+1\n11.0,up\n12.0,-1\n"
    with pytest.raises(InputError, match=r"^stdin names each reading's direction in its direction column, and "
                                         r"--direction \+1 was given too; expected one of them"):
        correct_stream(Compensator(model), io.BytesIO(data), io.BytesIO(), direction=1)
    sink = io.BytesIO()
    with pytest.raises(InputError, match=r"^line 3 of stdin: expected \+1, -1, cw or ccw in column 2 \(direction\), "
                                         r"the direction of a reading for a directional model, got '11.0,up'$"):
        correct_stream(Compensator(model), io.BytesIO(data), sink)
    assert len(sink.getvalue().split()) == 1  # the line before it is answered
    sink = io.BytesIO()
    correct_stream(Compensator(model), io.BytesIO(data), sink, skip_bad=True)
    assert sink.getvalue().split()[1] == b"nan"
    plain = io.BytesIO()  # another kind of model ignores the column, as before
    correct_stream(Compensator(encal.fit(CAL, "fourier")), io.BytesIO(data), plain)
    assert len(plain.getvalue().split()) == 3


# strict6: a reading only Python reads as a number, or beyond +-1e9 degrees, is a malformed line on every path
# of the stream (NumPy's plain decimals, the block of floats with an exponent, the careful reader, a CSV column)
@pytest.mark.parametrize("block, bad_line", [
    (b"10\n20\n1e308\n30\n", 3),  # was 295.99 degrees: the residue of a double beyond any turn
    (b"1.5e1\n-1e10\n", 2),
    (b"encoder_deg,x\n10,1\n1e308,2\n", 3),
    (b"# a comment\n10\n1000000001\n", 3),
    (b"10\n1_0\n", 2),  # was 10
    ("10\n\uff120\n".encode(), 2),  # a full-width two: was 20
    (b"encoder_deg\n10\n2_0\n", 3),
])
def test_a_reading_only_python_reads_or_beyond_1e9_degrees_is_a_malformed_line(block, bad_line):
    from encal._core.errors import InputError

    compensator = Compensator(encal.fit(CAL, "fourier"))
    for sizes in ([len(block)], [1] * len(block)):  # one read, and a byte at a time (each line its own block)
        sink = io.BytesIO()
        with pytest.raises(InputError, match=rf"^line {bad_line} of stdin: expected .*(1e\+09|underscore|U\+FF12)"):
            correct_stream(compensator, _Chunks(block, sizes), sink)
        answers = sink.getvalue().split()
        skipped = io.BytesIO()
        correct_stream(compensator, _Chunks(block, sizes), skipped, skip_bad=True)
        assert skipped.getvalue().split()[:len(answers) + 1] == answers + [b"nan"]
    edge = io.BytesIO()  # the bound itself is an angle
    correct_stream(compensator, io.BytesIO(b"1e9\n-1000000000\n1000000000.0\n"), edge)
    assert np.allclose(np.array(edge.getvalue().split(), dtype=float),
                       compensator.correct(np.array([1e9, -1e9, 1e9])), rtol=0, atol=1e-9)
