"""Exceptions raised by deltacal.

Every exception carries the offending values and says them in its message, so
that the command line can print it on one line without a traceback.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # numpy is not imported here, so that `deltacal --version` starts fast
    import numpy as np


class DeltacalError(Exception):
    """Base class of every error deltacal raises on purpose."""


class InputError(DeltacalError, ValueError):
    """A file, key, column or value given by the user is wrong.

    Attributes:
        source: File (or other source) the bad value came from, or "".
        location: Where in the source: "row 4, column q1_deg", "key geometry.arm_length_mm".
        detail: What is wrong.
    """

    def __init__(self, detail: str, source: str = "", location: str = "") -> None:
        self.source = str(source)
        self.location = location
        self.detail = detail
        parts = [p for p in (self.source, location) if p]
        prefix = ": ".join(parts)
        super().__init__(f"{prefix}: {detail}" if prefix else detail)


class GeometryError(DeltacalError, ValueError):
    """A geometry is impossible (negative length, rods too short to reach...)."""


class AssemblyError(DeltacalError):
    """No assembly of the closed loops exists at some joint readings.

    Attributes:
        indices: Indices, in the batch, of the readings that failed.
        readings: The failing readings [rad], shape (k, 3).
        residual: The largest constraint residual reached [mm].
    """

    def __init__(self, message: str, indices=(), readings=None, residual: float = float("nan")):
        self.indices = list(indices)
        self.readings = readings
        self.residual = residual
        super().__init__(message)


class UnreachableError(DeltacalError):
    """A target is out of reach, or too close to a singularity to be commanded.

    Attributes:
        indices: Indices, in the batch, of the failing targets.
        targets: The failing targets [mm], shape (k, 3).
        reason: Why: one of :data:`UnreachableError.REASONS` (``"out_of_reach"``,
            ``"singular"``, ``"check_failed"``, ``"other_assembly"``: reached only in another
            assembly than the one the robot is in when it comes from its workspace; for corrected
            targets, ``"controller_out_of_reach"`` and ``"controller_singular"``: the controller's
            own model cannot command the joints that put the real robot there; ``"not_held"``:
            where a printer's calibration does not hold, refused when asked). Callers branch on it,
            never on the message.
    """

    OUT_OF_REACH = "out_of_reach"
    SINGULAR = "singular"
    CHECK_FAILED = "check_failed"
    OTHER_ASSEMBLY = "other_assembly"
    CONTROLLER_OUT_OF_REACH = "controller_out_of_reach"
    CONTROLLER_SINGULAR = "controller_singular"
    NOT_HELD = "not_held"
    REASONS = (OUT_OF_REACH, SINGULAR, CHECK_FAILED, OTHER_ASSEMBLY, CONTROLLER_OUT_OF_REACH,
               CONTROLLER_SINGULAR, NOT_HELD)
    #: the words used for each reason in messages
    WORDS = {
        OUT_OF_REACH: "out of reach of the robot",
        SINGULAR: "too close to a singularity",
        CHECK_FAILED: "not reached by the joints computed (the output check failed)",
        OTHER_ASSEMBLY: ("reached only in another assembly of the rods (the robot coming along a straight "
                         "line from its workspace centre does not get there)"),
        CONTROLLER_OUT_OF_REACH: ("not commandable through the controller's model (its model has no "
                                  "knee-out assembly at the joints that put the robot there)"),
        CONTROLLER_SINGULAR: "too close to a singularity of the controller's model",
        NOT_HELD: ("where the calibration does not hold (its correction's σ there is above the bound: the "
                   "measurements do not determine it)"),
    }

    def __init__(self, message: str, indices=(), targets=None, reason: str = OUT_OF_REACH):
        if reason not in self.REASONS:
            raise ValueError(f"unknown reason {reason!r}; expected one of {self.REASONS}")
        self.indices = list(indices)
        self.targets = targets
        self.reason = reason
        super().__init__(message)

    @classmethod
    def from_mask(cls, bad: np.ndarray, targets: np.ndarray, reason: str = OUT_OF_REACH):
        """The error for the targets where ``bad`` is true, naming the first one and its index."""
        idx = bad.ravel().nonzero()[0]
        i = int(idx[0])
        what = cls.WORDS[reason]
        return cls(
            f"{idx.size} target(s) {what}, first: {targets[i].round(6).tolist()} mm (index {i})",
            idx,
            targets[idx],
            reason,
        )


class ConvergenceError(DeltacalError):
    """An iterative solver did not converge.

    Attributes:
        residual: The residual reached when it stopped.
    """

    def __init__(self, message: str, residual: float = float("nan")):
        self.residual = residual
        super().__init__(message)


class IdentificationError(DeltacalError):
    """The measurements cannot identify what was asked (too few, rank deficient...).

    Attributes:
        detail: What is wrong, without the rows it concerns.
        rows: Indices of the measurements at fault (empty when none in particular); the
            message names them as 1-based measurement rows, and the command line, which
            knows the file, names their lines instead.
    """

    def __init__(self, detail: str, rows=()) -> None:
        self.detail = detail
        self.rows = [int(k) for k in rows]
        if self.rows:
            shown = ", ".join(str(k + 1) for k in self.rows[:10]) + (", ..." if len(self.rows) > 10 else "")
            detail = f"measurement row{'s' if len(self.rows) > 1 else ''} {shown}: {detail}"
        super().__init__(detail)


class ResourceError(DeltacalError):
    """A problem too large for the memory this process may use, refused before it is built.

    Attributes:
        needed: Estimated memory the problem needs [bytes].
        available: Memory available to the process [bytes].
    """

    def __init__(self, message: str, needed: float, available: float) -> None:
        self.needed = float(needed)
        self.available = float(available)
        super().__init__(message)


class PoorFitError(IdentificationError):
    """The fit is far from the σ given, or its geometry implausible; nothing should be written.

    Attributes:
        result: The fit that was refused (an :class:`~deltacal.identification.IdentificationResult`).
        causes: The other readings of the data that the data support, most likely first (prose).
        codes: Why, as codes of :data:`PoorFitError.CODES`, one per reason found, most telling
            first: ``"readings"`` (another reading of the data fits: its words are in ``causes``),
            ``"richer_model"`` (the complete model fits these data), ``"implausible"`` (the
            identified geometry is implausible), ``"large_residuals"`` (s0² beyond the gate, no
            single cause found). Callers branch on these, never on the message.
        model: The richer model that fits the same data (``"complete"``) when ``"richer_model"``
            is among the codes, else "".
    """

    READINGS = "readings"
    RICHER_MODEL = "richer_model"
    IMPLAUSIBLE = "implausible"
    LARGE_RESIDUALS = "large_residuals"
    CODES = (READINGS, RICHER_MODEL, IMPLAUSIBLE, LARGE_RESIDUALS)

    def __init__(self, message: str, result, causes: list[str], codes: tuple[str, ...] = (),
                 model: str = "") -> None:
        unknown = [c for c in codes if c not in self.CODES]
        if unknown:
            raise ValueError(f"unknown poor-fit code {unknown[0]!r}; expected one of {self.CODES}")
        self.result = result
        self.causes = causes
        self.codes = tuple(codes)
        self.model = model
        super().__init__(message)


class PlanningError(DeltacalError):
    """No pose set satisfies what was asked (κ rule never met, too few candidates...)."""


class ViewerError(DeltacalError):
    """The scene cannot be shown or rendered (no browser, browser failed, server failed)."""


class UsageError(DeltacalError):
    """The command line is wrong (a path that does not exist, an output over an input): status 2."""


class InputWarning(UserWarning):
    """Something in an input file looks wrong but may be right (units, repeated rows).

    The command line prints these on one line each; library users get them
    through the :mod:`warnings` machinery.
    """
