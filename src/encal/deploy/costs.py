"""What a reading costs on a microcontroller: C operations per reading of each deployed form.

Counted in the generated C (:mod:`encal.deploy.targets`): loads, integer and float
arithmetic, conversions and compares. Calls to ``sinf``/``cosf`` are counted apart
(a call counts as :data:`CALL_OPERATIONS` when costs are compared). Instructions on
a Cortex-M4F build are measured by ``benchmarks/bench_mcu.py`` (BENCHMARKS.md).
"""

__all__ = ["OPERATIONS", "CALL_OPERATIONS", "reading_cost_key"]

#: C operations per reading (loads, integer and float arithmetic, conversions, compares; calls
#: to sinf/cosf counted apart), by target, form ("table": a linearly interpolated compact table;
#: "cubic": a cubic B-spline table; "formula") and function. Instruction counts on a
#: Cortex-M4F build are measured by benchmarks/bench_mcu.py.
OPERATIONS = {
    ("cortex-m4f", "table", "error_lsb"): 15,
    ("cortex-m4f", "table", "correct_code"): 22,
    ("cortex-m4f", "table", "correct_deg"): 21,
    ("cortex-m4f", "cubic", "error_lsb"): 40,
    ("cortex-m4f", "cubic", "correct_code"): 47,
    ("cortex-m4f", "cubic", "correct_deg"): 46,
    ("fixed", "table", "error_bam32"): 14,
    ("fixed", "table", "correct_code"): 23,
    ("fixed", "cubic", "error_bam32"): 37,
    ("fixed", "cubic", "correct_code"): 46,
    ("cortex-m4f", "formula", "per_term"): 11,
}

#: Operations a sinf or cosf call is counted as when deployments are compared.
CALL_OPERATIONS = 50


def reading_cost_key(target, bits):
    """The function whose cost a table's reading is quoted at: the error in LSB of a code (``error_lsb``; in BAM32
    for ``fixed``), or, when the encoder's resolution is unknown and only the angle functions are exported, the
    correction of an angle in degrees (``correct_deg``)."""
    if target == "fixed":
        return "error_bam32"
    return "error_lsb" if bits is not None else "correct_deg"
