"""A simulated encoder: one resolver on one mount, read by one or more decoders over epochs."""

import operator
from dataclasses import dataclass

import numpy as np

from .._core.errors import InputError
from ._parameters import (
    DecoderParameters,
    MountParameters,
    ResolverParameters,
    TableParameters,
    draw_decoder,
    draw_mount,
    draw_resolver,
    draw_table,
    drift_mount,
    drift_resolver,
)

__all__ = ["SimulatedEncoder", "EncoderState", "draw_encoder"]

# Sub-streams of an encoder's own entropy: one per epoch drift, one per extra decoder.
_EPOCH_STREAM = 0
_DECODER_STREAM = 1


@dataclass(frozen=True, eq=False)
class EncoderState:
    """Everything that fixes an encoder's readings at one epoch with one decoder.

    Attributes
    ----------
    table, mount, resolver, decoder
        Parameters in effect (see ``encal.simulate._parameters``).
    reference_phase : float
        Carrier phase the decoder demodulates against, radians: the resolver's
        phase lead when the decoder was set up plus the decoder's residual
        reference-phase error. It stays fixed while the resolver drifts.
    """

    table: TableParameters
    mount: MountParameters
    resolver: ResolverParameters
    decoder: DecoderParameters
    reference_phase: float


@dataclass(frozen=True, eq=False)
class SimulatedEncoder:
    """A resolver encoder drawn from the simulator's parameter distributions.

    Epoch 0 with decoder 0 is the state drawn by :func:`draw_encoder`. Later
    epochs add one random drift per epoch (cumulative); decoder ``d > 0`` is
    another converter, drawn afresh, reading the same resolver on the same
    mount. Both are drawn from the encoder's own random streams, so
    ``state(epoch, decoder)`` always returns the same parameters.

    Attributes
    ----------
    name : str
        Encoder name, e.g. ``'enc1'``.
    table, mount, resolver, decoder
        Parameters at epoch 0 with decoder 0.
    stream_entropy : int
        Seed of the epoch-drift and extra-decoder streams.
    """

    name: str
    table: TableParameters
    mount: MountParameters
    resolver: ResolverParameters
    decoder: DecoderParameters
    stream_entropy: int

    def state(self, epoch=0, decoder=0):
        """The encoder's parameters at ``epoch`` read by decoder ``decoder``.

        Parameters
        ----------
        epoch : int, default=0
            Calibration epoch; 0 is the first.
        decoder : int, default=0
            Decoder index; 0 is the original converter.

        Returns
        -------
        EncoderState
        """
        epoch = _index("epoch", epoch)
        decoder = _index("decoder", decoder)
        mount, resolver = self.mount, self.resolver
        for step in range(1, epoch + 1):
            rng = self._stream(_EPOCH_STREAM, step)
            mount, resolver = drift_mount(mount, rng), drift_resolver(resolver, rng)
        converter = self.decoder if decoder == 0 else draw_decoder(self._stream(_DECODER_STREAM, decoder))
        return EncoderState(
            table=self.table,
            mount=mount,
            resolver=resolver,
            decoder=converter,
            reference_phase=self.resolver.phase_lead + converter.reference_phase_error,
        )

    def _stream(self, kind, index):
        return np.random.default_rng(np.random.SeedSequence(self.stream_entropy, spawn_key=(kind, index)))


def _index(what, value):
    try:
        value = operator.index(value)
    except TypeError:
        raise InputError(f"the {what} index must be an integer >= 0; got {value!r}") from None
    if value < 0:
        raise InputError(f"the {what} index must be an integer >= 0; got {value}")
    return value


def draw_encoder(rng=None, name="enc1"):
    """Draw one encoder: rotary table, mount, resolver and decoder (spec §4.2).

    Parameters
    ----------
    rng : numpy.random.Generator, int, numpy.random.SeedSequence or None, default=None
        Source of randomness; an int or seed sequence gives a reproducible encoder.
    name : str, default='enc1'
        Encoder name carried into its calibrations.

    Returns
    -------
    SimulatedEncoder

    Examples
    --------
    >>> a, b = draw_encoder(7), draw_encoder(7)
    >>> a.mount == b.mount
    True
    """
    rng = np.random.default_rng(rng)
    return SimulatedEncoder(
        name=str(name),
        table=draw_table(rng),
        mount=draw_mount(rng),
        resolver=draw_resolver(rng),
        decoder=draw_decoder(rng),
        stream_entropy=int(rng.integers(0, 2**63)),
    )
