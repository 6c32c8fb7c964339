"""Fleets of simulated encoders with the paper's calibration runs, and the built-in demo fleet."""

import operator
from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError
from ._encoder import SimulatedEncoder, draw_encoder
from ._run import TEST_GRID_DEG, TRAINING_GRID_DEG, SimulatedRun, calibration_run

__all__ = ["FleetMember", "RUN_NAMES", "DEMO_SEEDS", "DEMO_EXTRA_SEED", "demo_fleet", "simulate_fleet",
           "simulate_member"]

#: The runs of every fleet member, in file order.
RUN_NAMES = ("train", "test", "epoch2", "decoder2")

#: Seeds of the demo encoders enc1..enc4, picked once from a search so that the
#: fleet looks like the paper's (see docs/simulator.md, "Choosing the demo seeds").
DEMO_SEEDS = (159, 587, 99, 3882)

#: Seed of the encoders enc5, enc6, ... that extend the demo fleet beyond four.
DEMO_EXTRA_SEED = 20091119


@dataclass(frozen=True, eq=False)
class FleetMember:
    """One simulated encoder with its four calibration runs.

    Attributes
    ----------
    encoder : SimulatedEncoder
        The encoder; call :func:`calibration_run` on it for more runs.
    train : SimulatedRun
        Training grid 0, 2, ..., 358 degrees, epoch 0, decoder 0.
    test : SimulatedRun
        Test grid 1, 3, ..., 359 degrees, same epoch and decoder.
    epoch2 : SimulatedRun
        Training grid again at the next epoch (drifted mount and resolver).
    decoder2 : SimulatedRun
        Training grid at epoch 0, read by a second decoder.
    seed : numpy.random.SeedSequence
        Where the encoder and its runs come from (``entropy`` and ``spawn_key``).
    """

    encoder: SimulatedEncoder
    train: SimulatedRun
    test: SimulatedRun
    epoch2: SimulatedRun
    decoder2: SimulatedRun
    seed: np.random.SeedSequence | None = None

    @property
    def name(self):
        """Encoder name."""
        return self.encoder.name

    @property
    def runs(self):
        """The runs by name, in the order of :data:`RUN_NAMES`."""
        return {name: getattr(self, name) for name in RUN_NAMES}


def simulate_member(seed_sequence, name):
    """Draw one encoder from ``seed_sequence`` and simulate its four runs.

    Parameters
    ----------
    seed_sequence : numpy.random.SeedSequence
        Source of the encoder's parameters and of the runs' per-reading noise.
    name : str
        Encoder name.

    Returns
    -------
    FleetMember
    """
    encoder_seed, noise_seed = seed_sequence.spawn(2)
    encoder = draw_encoder(np.random.default_rng(encoder_seed), name=name)
    noise = [np.random.default_rng(s) for s in noise_seed.spawn(len(RUN_NAMES))]
    return FleetMember(
        encoder=encoder,
        train=calibration_run(encoder, TRAINING_GRID_DEG, rng=noise[0]),
        test=calibration_run(encoder, TEST_GRID_DEG, rng=noise[1]),
        epoch2=calibration_run(encoder, TRAINING_GRID_DEG, epoch=1, rng=noise[2]),
        decoder2=calibration_run(encoder, TRAINING_GRID_DEG, decoder=1, rng=noise[3]),
        seed=seed_sequence,
    )


def _count(n_encoders, smallest):
    try:
        count = operator.index(n_encoders)
    except TypeError:
        raise InputError(f"the number of encoders must be an integer >= {smallest}; got {n_encoders!r}") from None
    if count < smallest:
        raise InputError(f"the number of encoders must be an integer >= {smallest}; got {count}")
    return count


def _seed(seed):
    if seed is None:
        return None
    try:
        seed = operator.index(seed)
    except TypeError:
        raise InputError(f"the seed must be an integer >= 0 or None; got {seed!r}") from None
    if seed < 0:
        raise InputError(f"the seed must be an integer >= 0 or None; got {seed}")
    return seed


def simulate_fleet(n_encoders, seed=None, *, first_number=1):
    """Draw ``n_encoders`` encoders from one seed, each with the four runs of :class:`FleetMember`.

    Encoder ``k`` depends only on ``seed`` and ``k``, so a larger fleet from
    the same seed starts with the encoders of a smaller one.

    Parameters
    ----------
    n_encoders : int
        Number of encoders, >= 1.
    seed : int or None, default=None
        Seed (>= 0) of the whole fleet; ``None`` draws fresh entropy.
    first_number : int, default=1
        Number of the first encoder: names are ``enc<first_number>``, ... and
        encoder ``enc<k>`` is drawn from the stream ``k - 1`` of the seed.

    Returns
    -------
    tuple of FleetMember
    """
    count = _count(n_encoders, 1)
    first = _count(first_number, 1)
    entropy = np.random.SeedSequence(_seed(seed)).entropy
    return tuple(
        simulate_member(np.random.SeedSequence(entropy, spawn_key=(k - 1,)), f"enc{k}")
        for k in range(first, first + count)
    )


def demo_fleet(n_encoders=4):
    """The built-in demo fleet: encoders 'enc1'..'enc4' that look like the paper's.

    Each encoder comes from a fixed seed (:data:`DEMO_SEEDS`), so the fleet is
    the same on every machine and every call. Training-run MAE spans
    0.56-1.73 arcmin and the extremes are -4.43 / +3.11 arcmin (all measured
    values in docs/simulator.md).

    Parameters
    ----------
    n_encoders : int, default=4
        Fewer than four gives the first ones; more adds ``enc5``, ``enc6``, ...
        drawn from :data:`DEMO_EXTRA_SEED` with :func:`simulate_fleet`.

    Returns
    -------
    tuple of FleetMember
    """
    count = _count(n_encoders, 1)
    chosen = tuple(
        simulate_member(np.random.SeedSequence(seed), f"enc{k}")
        for k, seed in enumerate(DEMO_SEEDS[:count], start=1)
    )
    extra = count - len(chosen)
    if extra > 0:
        chosen += simulate_fleet(extra, DEMO_EXTRA_SEED, first_number=len(DEMO_SEEDS) + 1)
    return chosen
