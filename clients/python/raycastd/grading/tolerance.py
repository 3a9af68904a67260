"""Numeric tolerances as instructors know them (the PrairieLearn checks, written out).

- `relabs` (the default): |a − b| ≤ atol + rtol·|b|, b the reference (PrairieLearn's
  `is_correct_scalar_ra`, NumPy's `isclose`); defaults rtol = 1e-2, atol = 1e-8.
- `sigfigs = n`: |a − b| ≤ 0.51·10^(⌊log10 |b|⌋ − n + 1), the answer agrees with b to n
  significant figures (PrairieLearn's `is_correct_scalar_sf`).
- `decimals = n`: |a − b| ≤ 0.51·10^(−n), agreement to n digits after the point
  (PrairieLearn's `is_correct_scalar_dd`).

The default atol is aware of float32 and of the scene's size: a student's single-precision ray
tracer computes a coordinate of size L with an error of a few units in the last place, so a
reference of exactly 0 (the x of a hit point on the axis) must accept ±(a few)·ε₃₂·L. The
default atol is therefore max(1e-8, 64·ε₃₂·scale), ε₃₂ = 2⁻²³, where `scale` is the scene's
extent for coordinates, extent/|d| for t, and 1 for unit normals. An atol the instructor writes
is used as written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

EPS32 = 2.0**-23
FLOAT32_ULPS = 64.0
DEFAULT_RTOL = 1e-2
DEFAULT_ATOL = 1e-8


@dataclass(frozen=True)
class Tolerance:
    """One comparison rule: `kind` is relabs, sigfigs or decimals."""

    kind: str = "relabs"
    rtol: float = DEFAULT_RTOL
    atol: float | None = None  # None: the float32-aware default, scaled per quantity
    digits: int = 3

    @staticmethod
    def parse(spec: Mapping[str, Any] | None, base: "Tolerance | None" = None) -> "Tolerance":
        """A tolerance from a question file table (`{rtol, atol}`, `{sigfigs}` or
        `{decimals}`); keys not given come from `base`."""
        base = base or Tolerance()
        if not spec:
            return base
        unknown = set(spec) - {"rtol", "atol", "sigfigs", "decimals"}
        if unknown:
            raise ValueError(f"unknown tolerance keys: {', '.join(sorted(unknown))}")
        if "sigfigs" in spec and "decimals" in spec:
            raise ValueError("give sigfigs or decimals, not both")
        if "sigfigs" in spec:
            return Tolerance("sigfigs", digits=_positive_int(spec["sigfigs"], "sigfigs"))
        if "decimals" in spec:
            return Tolerance("decimals", digits=_nonnegative_int(spec["decimals"], "decimals"))
        rtol = float(spec.get("rtol", base.rtol if base.kind == "relabs" else DEFAULT_RTOL))
        atol = spec.get("atol", base.atol if base.kind == "relabs" else None)
        if rtol < 0 or (atol is not None and float(atol) < 0):
            raise ValueError("rtol and atol must be ≥ 0")
        return Tolerance("relabs", rtol=rtol, atol=None if atol is None else float(atol))

    def bound(self, reference: float, scale: float = 1.0) -> float:
        """The largest |answer − reference| accepted."""
        if self.kind == "sigfigs":
            if reference == 0:
                return 0.51 * 10.0 ** (-self.digits)
            return 0.51 * 10.0 ** (math.floor(math.log10(abs(reference))) - self.digits + 1)
        if self.kind == "decimals":
            return 0.51 * 10.0 ** (-self.digits)
        return self.effective_atol(scale) + self.rtol * abs(reference)

    def effective_atol(self, scale: float) -> float:
        if self.atol is not None:
            return self.atol
        return max(DEFAULT_ATOL, FLOAT32_ULPS * EPS32 * abs(scale))

    def accepts(self, answer: float, reference: float, scale: float = 1.0) -> bool:
        """Whether `answer` matches `reference`; infinities (a miss) match only themselves."""
        if math.isinf(reference) or math.isinf(answer):
            return answer == reference
        if math.isnan(answer) or math.isnan(reference):
            return False
        return abs(answer - reference) <= self.bound(reference, scale)

    def describe(self, reference: float, scale: float = 1.0) -> str:
        """`± 0.0727` style text for feedback."""
        if self.kind == "sigfigs":
            return f"to {self.digits} significant figures"
        if self.kind == "decimals":
            return f"to {self.digits} decimal places"
        return f"± {self.bound(reference, scale):.3g}"


def _positive_int(v: Any, what: str) -> int:
    if not isinstance(v, int) or isinstance(v, bool) or v < 1:
        raise ValueError(f"{what} must be a positive integer, not {v!r}")
    return v


def _nonnegative_int(v: Any, what: str) -> int:
    if not isinstance(v, int) or isinstance(v, bool) or v < 0:
        raise ValueError(f"{what} must be an integer ≥ 0, not {v!r}")
    return v
