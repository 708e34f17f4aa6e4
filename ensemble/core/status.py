"""Per-chain result codes: a chain that goes wrong is flagged (and, if non-finite, frozen), never raised."""

from __future__ import annotations

from enum import IntEnum

from hertzian.kernels.features import STATUS_ENERGY_DRIFT, STATUS_NON_FINITE, STATUS_OK, STATUS_OVERLAP_BEYOND_VALIDITY


class Status(IntEnum):
    """Status of one chain after a run; ``OK = 0``. The values are hertzian.kernels.features' STATUS_* codes.

    Precedence: the record kernel sets NON_FINITE whatever the chain's code was (and the solvers then
    freeze the chain); it sets OVERLAP_BEYOND_VALIDITY only on an OK chain; the runner sets
    ENERGY_DRIFT at the end only on a chain still OK. The array lives in ``State.status``, shared by
    both halves of a ping-pong pair.
    """

    OK = STATUS_OK
    NON_FINITE = STATUS_NON_FINITE
    OVERLAP_BEYOND_VALIDITY = STATUS_OVERLAP_BEYOND_VALIDITY
    ENERGY_DRIFT = STATUS_ENERGY_DRIFT
    TOLERANCE_MISSED = 4
    """Set on the host only (ensemble/core/error_estimate.py), on a chain still OK or ESTIMATE_UNCERTAIN."""
    ESTIMATE_UNCERTAIN = 5
    """Set on the host only (ensemble/core/error_estimate.py), on a chain still OK."""

    @property
    def message(self) -> str:
        return STATUS_MESSAGES[self]


STATUS_MESSAGES = {
    Status.OK: "ok",
    Status.NON_FINITE: "state became non-finite (NaN/inf); the chain was frozen at the next record",
    Status.OVERLAP_BEYOND_VALIDITY: "an overlap exceeded 0.1·diameter, beyond where the Hertz law holds",
    Status.ENERGY_DRIFT: "energy error above the tolerance (1e-2 of the injected energy by default)",
    Status.TOLERANCE_MISSED: "error estimate above integrator.tolerance at the step it chose (the finest tried when none met it)",
    Status.ESTIMATE_UNCERTAIN: "a contact opened with plain steps (integrator.events = off): the error estimate "
    "is within 3x of the true error on about 90 % of such points, not 95 %",
}


def status_attrs() -> dict[str, str]:
    """{code: 'NAME: message'} for store attributes."""
    return {str(int(s)): f"{s.name}: {s.message}" for s in Status}


FAILED = (Status.NON_FINITE, Status.OVERLAP_BEYOND_VALIDITY, Status.ENERGY_DRIFT, Status.TOLERANCE_MISSED)
"""Codes that mean a chain's result cannot be trusted as asked for; ``hertzian run`` and ``hertzian sweep`` exit
with code 3 when any chain ends with one (ESTIMATE_UNCERTAIN is a caveat on the error estimate, not a failure)."""


def failure_line(status) -> str | None:
    """One line counting the chains of ``status`` (any int array) that ended with a :data:`FAILED` code, by code
    and with the first one's meaning; None when there are none."""
    import numpy as np

    codes = np.asarray(status).reshape(-1)
    counts = {s: int(np.count_nonzero(codes == int(s))) for s in FAILED}
    counts = {s: k for s, k in counts.items() if k}
    if not counts:
        return None
    first = next(iter(counts))
    named = ", ".join(f"{s.name} {k}" for s, k in counts.items())
    return (
        f"{sum(counts.values())} of {codes.size} chains did not end OK ({named}; {first.name}: {first.message}); "
        "their status is in the store"
    )
