"""What the stepper firmwares (Klipper, Mechaduino) share: the stepper's frame, fixed by ``step_zero_deg``.

Both firmwares tie the encoder table to the stepper's electrical phase: Klipper reads the driver phase
from the list index (``index & 3``), Mechaduino commutates with the table's angle (``output(-y ± PA)``).
A table is right only in the frame of a full step at driver phase 0 (electrical zero). A calibration's
reference zero is arbitrary (the mean error is removed from step calibrations, a reference encoder has
its own zero), so encal is told where that step sits: ``step_zero_deg``, the reference angle (degrees)
of a full step at driver phase 0. Klipper's list also runs in the stepper's positive direction, which encal
is told against the reference's: ``step_direction`` (Mechaduino's own calibration fixes its direction: forward
steps count the encoder up).
"""

import numpy as np

from ..._core.errors import InputError
from ..._core.parameters import check_number

__all__ = ["check_step_zero", "check_step_direction", "check_full_steps"]


def check_step_zero(step_zero_deg, firmware, caller):
    """``step_zero_deg`` as a finite float, or the one-sentence refusal naming the option when it is None."""
    if step_zero_deg is None:
        raise InputError(
            f"a {firmware} table is tied to the stepper's electrical phase, and encal does not know where a full "
            "step at driver phase 0 (electrical zero) sits relative to the calibration's reference zero; expected "
            f"its reference angle in degrees, got none; pass --step-zero DEG (step_zero_deg= in {caller})")
    return check_number(step_zero_deg, "step_zero_deg", caller, note="the reference angle of a full step at driver "
                        "phase 0, degrees")


def check_step_direction(step_direction, caller):
    """``step_direction`` as the int 1 or -1: which way the stepper's positive full steps turn the reference."""
    from ..._core.parameters import invalid

    if step_direction is None:
        raise InputError(
            f"{caller} needs the way the stepper's positive full steps turn the reference, got none; pass "
            "--step-direction 1 if they raise the reference angle or -1 if they lower it (step_direction= in "
            f"{caller})")
    if isinstance(step_direction, bool) or step_direction not in (1, -1):
        raise invalid("step_direction", caller, "1 or -1 (1: the stepper's positive full steps raise the reference "
                      "angle, -1: they lower it)", step_direction)
    return int(step_direction)


def check_full_steps(full_steps, caller):
    """Full steps per turn: an int from 8 to 4096 and a multiple of 4 (a two-phase stepper's electrical cycle)."""
    from ..._core.parameters import check_int, invalid

    full_steps = check_int(full_steps, "full_steps", caller, low=8, high=4096, note="full steps per turn")
    if full_steps % 4:
        raise invalid("full_steps", caller, "a multiple of 4 (a two-phase stepper's electrical cycle is 4 full "
                      "steps; the firmware reads the driver phase as the step index & 3)", full_steps)
    return full_steps


def wrap_period(angle_deg, period_deg):
    """Angles wrapped to [-period/2, period/2)."""
    return (np.asarray(angle_deg, dtype=float) + 0.5 * period_deg) % period_deg - 0.5 * period_deg
