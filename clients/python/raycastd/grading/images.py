"""Comparing a student's render with the reference render of the same camera.

A pixel differs when any channel differs by more than `pixel_tolerance` (0–255). The image
passes when at most `max_bad_fraction` (f) of its pixels differ; with partial credit, the credit
then falls linearly with the share of differing pixels, from 1 at f to 0 at 10·f (or at every
pixel, when 10·f > 1): an image wrong in ten times the allowed share earns nothing. The diff image shows the reference dimmed to a quarter in grey, with every
differing pixel in red.
"""

from __future__ import annotations

from dataclasses import dataclass

from raycastd.grading.questions import ImageSpec
from raycastd.png import Image


@dataclass
class ImageCheck:
    credit: float
    detail: str
    bad_fraction: float
    diff: Image | None


def compare_images(ref: Image, got: Image, spec: ImageSpec) -> ImageCheck:
    if (got.width, got.height) != (ref.width, ref.height):
        return ImageCheck(
            0.0,
            f"your image is {got.width}x{got.height}, expected {ref.width}x{ref.height}",
            1.0,
            None,
        )
    tol = spec.pixel_tolerance
    a, b = ref.pixels, got.pixels
    diff = bytearray(len(a))
    bad = 0
    worst = 0
    for i in range(0, len(a), 3):
        d = max(abs(a[i] - b[i]), abs(a[i + 1] - b[i + 1]), abs(a[i + 2] - b[i + 2]))
        worst = max(worst, d)
        if d > tol:
            bad += 1
            diff[i] = 255
        else:
            g = (a[i] * 3 + a[i + 1] * 6 + a[i + 2]) // 40  # a quarter of the luma
            diff[i] = diff[i + 1] = diff[i + 2] = g
    n = ref.width * ref.height
    frac = bad / n
    allowed = spec.max_bad_fraction
    if frac <= allowed:
        credit = 1.0
    elif spec.partial_credit and allowed < 1:
        zero = min(1.0, 10.0 * allowed)
        credit = max(0.0, 1.0 - (frac - allowed) / (zero - allowed)) if zero > allowed else 0.0
    else:
        credit = 0.0
    detail = (
        f"{bad} of {n} pixels ({frac:.2%}) differ by more than {tol}/255 "
        f"(allowed: {allowed:.2%}); largest difference {worst}/255"
    )
    return ImageCheck(credit, detail, frac, Image(ref.width, ref.height, diff))
