"""Comparing one student answer with the reference, per kind of question.

Each checker takes the reference of one item (a ray or a point), the student's value for it and
the question, and returns a `Check`: the credit in [0, 1] and a sentence saying what was
expected and what was given (shown only when the question is visible). Values a student writes
are read leniently: `"sphere 3"`, `"Sphere3"` and (with `index_base = 1`) `3` name the same
object; `"none"`, `"miss"`, `false` and `-1` say "nothing is hit"; `"I_4"`, `"i4"` and `4` name
the ray-tree point I4.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Sequence

from raycastd.grading.questions import Question, norm_name
from raycastd.grading.tolerance import Tolerance

MISS_WORDS = {"none", "miss", "nothing", "no hit", "null", "", "inf", "infinity", "n/a", "-"}


class AnswerError(ValueError):
    """The student's value cannot be read as the kind of answer asked for."""


@dataclass
class Check:
    """The result of comparing one item."""

    credit: float
    detail: str  # "expected …, got …" (or "…" when correct)


def is_miss_word(v: Any) -> bool:
    if v is None or v is False:
        return True
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return v == -1 or (isinstance(v, float) and math.isinf(v))
    return isinstance(v, str) and v.strip().lower() in MISS_WORDS


def number(v: Any) -> float:
    """A student's number; a miss word is +inf."""
    if isinstance(v, bool):
        raise AnswerError(f"{v!r} is not a number")
    if isinstance(v, (int, float)):
        return float(v)
    if isinstance(v, str):
        if v.strip().lower() in MISS_WORDS:
            return math.inf
        try:
            return float(v)
        except ValueError:
            raise AnswerError(f"{v!r} is not a number") from None
    if v is None:
        return math.inf
    raise AnswerError(f"{v!r} is not a number")


def vector(v: Any) -> list[float] | None:
    """A student's 3-vector, or None for a miss word."""
    if is_miss_word(v) and not isinstance(v, (int, float)):
        return None
    if isinstance(v, str):
        parts = [p for p in re.split(r"[\s,;()\[\]]+", v) if p]
        v = parts
    if not isinstance(v, (list, tuple)) or len(v) != 3:
        raise AnswerError(f"{v!r} is not 3 numbers")
    return [number(x) for x in v]


def boolean(v: Any) -> bool:
    if isinstance(v, bool):
        return v
    if isinstance(v, (int, float)) and v in (0, 1):
        return bool(v)
    if isinstance(v, str):
        t = v.strip().lower()
        if t in ("true", "yes", "y", "hit", "inside", "1"):
            return True
        if t in ("false", "no", "n", "miss", "outside", "0"):
            return False
    raise AnswerError(f"{v!r} is not true/false")


def fmt(v: Any) -> str:
    if v is None:
        return "no hit"
    if isinstance(v, float):
        return "no hit (inf)" if math.isinf(v) else f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(fmt(x) for x in v) + ")"
    return str(v)


def check_first_hit(ref: tuple[int, str] | None, value: Any, q: Question) -> Check:
    """ref: (object index, name) or None for a miss."""
    expected = ref[1] if ref else None
    if is_miss_word(value):
        got_index = None
    elif ref is not None and ref[0] < 0:
        # an instructor's name in a scene whose objects the server numbers: names only (an
        # index answer cannot be matched, and 0 with index_base 1 had equalled the -1)
        if isinstance(value, str) and norm_name(value) == norm_name(ref[1]):
            return Check(1.0, f"{expected}")
        return Check(0.0, f"expected {fmt(expected)} (by name), got {value}")
    elif isinstance(value, int) and not isinstance(value, bool):
        got_index = value - q.index_base
    elif isinstance(value, str):
        if ref is not None and norm_name(value) == norm_name(ref[1]):
            return Check(1.0, f"{expected}")
        if value.strip().lstrip("-").isdigit():
            got_index = int(value) - q.index_base
        else:
            return Check(0.0, f"expected {fmt(expected)}, got {value}")
    else:
        raise AnswerError(f"{value!r} is not an object name or index")
    ok = (got_index is None and ref is None) or (ref is not None and got_index == ref[0])
    given = "no hit" if got_index is None else f"object {got_index + q.index_base}"
    return Check(
        1.0 if ok else 0.0, fmt(expected) if ok else f"expected {fmt(expected)}, got {given}"
    )


def check_scalar(ref: float, value: Any, tol: Tolerance, scale: float) -> Check:
    got = number(value)
    if math.isinf(ref) and got == -1:  # "-1 for no hit", as many student tracers write it
        got = math.inf
    if tol.accepts(got, ref, scale):
        return Check(1.0, fmt(ref))
    within = "" if math.isinf(ref) else f" ({tol.describe(ref, scale)})"
    return Check(0.0, f"expected {fmt(ref)}{within}, got {fmt(got)}")


def check_vector(
    ref: Sequence[float] | None, value: Any, tol: Tolerance, scale: float, either_sign: bool = False
) -> Check:
    got = vector(value)
    if ref is None or got is None:
        ok = ref is None and got is None
        return Check(float(ok), fmt(ref) if ok else f"expected {fmt(ref)}, got {fmt(got)}")

    def close(sign: float) -> bool:
        return all(tol.accepts(sign * g, r, scale) for g, r in zip(got, ref))

    if close(1.0) or (either_sign and close(-1.0)):
        return Check(1.0, fmt(list(ref)))
    return Check(
        0.0,
        f"expected {fmt(list(ref))} ({tol.describe(max(map(abs, ref)), scale)}), got {fmt(got)}",
    )


def check_hits(ref: Sequence[float], value: Any, tol: Tolerance, scale: float) -> Check:
    """Every t along a ray: credit = matched / max(expected, given), matched within tolerance."""
    if is_miss_word(value) and not isinstance(value, (int, float)):
        given: list[float] = []
    elif isinstance(value, (list, tuple)):
        given = sorted(number(v) for v in value if not (isinstance(v, float) and math.isinf(v)))
    else:
        given = [number(value)]
    left = list(given)
    matched = 0
    for r in sorted(ref):
        for i, g in enumerate(left):
            if tol.accepts(g, r, scale):
                matched += 1
                del left[i]
                break
    denom = max(len(ref), len(given))
    credit = 1.0 if denom == 0 else matched / denom
    if credit == 1.0:
        return Check(1.0, fmt(list(ref)) if ref else "no hits")
    return Check(
        credit,
        f"expected {fmt(sorted(ref)) if ref else 'no hits'}, got {fmt(given) if given else 'no hits'} ({matched} matched)",
    )


def check_bool(ref: bool, value: Any, yes: str, no: str) -> Check:
    got = boolean(value)
    word = yes if ref else no
    return (
        Check(1.0, word) if got == ref else Check(0.0, f"expected {word}, got {yes if got else no}")
    )


def labels(value: Any) -> set[str]:
    """Ray-tree point labels from a student's list: "I4", "i_4", 4 → "I4"."""
    if is_miss_word(value) and not isinstance(value, (int, float)):
        return set()
    items = value if isinstance(value, (list, tuple)) else re.split(r"[\s,;]+", str(value).strip())
    out = set()
    for item in items:
        if isinstance(item, bool):
            raise AnswerError(f"{item!r} is not a ray-tree point")
        if isinstance(item, int):
            out.add(f"I{item}")
            continue
        m = re.fullmatch(r"\s*[iI]?_?\{?(\d+)\}?\s*", str(item))
        if not m:
            raise AnswerError(f"{item!r} is not a ray-tree point (I1, I2, …)")
        out.add(f"I{int(m.group(1))}")
    return out


def check_tree_set(ref: set[str], all_points: Sequence[str], value: Any, what: str) -> Check:
    """Per point of the tree: right when the student puts it in the set exactly when it is."""
    got = labels(value)
    unknown = sorted(got - set(all_points))
    right = sum((p in got) == (p in ref) for p in all_points)
    credit = right / (len(all_points) + len(unknown)) if all_points or unknown else 1.0
    exp = ", ".join(sorted(ref, key=_label_key)) or "none"
    if credit == 1.0:
        return Check(1.0, exp)
    give = ", ".join(sorted(got, key=_label_key)) or "none"
    extra = f"; the tree has no {', '.join(unknown)}" if unknown else ""
    return Check(
        credit,
        f"{what}: expected {exp}, got {give} ({right} of {len(all_points)} points right{extra})",
    )


def _label_key(label: str) -> int:
    return int(label[1:]) if label[1:].isdigit() else 0


def check_int(ref: int, value: Any) -> Check:
    got = number(value)
    if got == ref:
        return Check(1.0, str(ref))
    return Check(0.0, f"expected {ref}, got {fmt(got)}")
