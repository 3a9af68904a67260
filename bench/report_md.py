"""Renders the rows that bench/run_all.py collected as docs/benchmarks.md.

A row is a dict. Tracing: {"kind": "trace", "workload", "rays", "peer", "variant", "mode",
"precision", "mrays_s", "measured_rays", "total_rays", "sampled", "agree_with_embree"?,
"answered_precision"?}. Build: {"kind": "build", "workload", "peer", "variant", "ms"}. A form a
peer does not offer: {"kind": "unavailable", "workload", "rays", "peer", "variant", "reason"}.
"""

from __future__ import annotations

from typing import Iterable

RAYS = ("coherent", "incoherent")
CEILING = ("raw_embree", "rtcIntersect1")


def find(rows: Iterable[dict], **match) -> dict | None:
    for r in rows:
        if all(r.get(k) == v for k, v in match.items()):
            return r
    return None


def fmt_rate(row: dict | None) -> str:
    if row is None:
        return "—"
    if row["kind"] == "unavailable":
        return "n/a"
    star = "\\*" if row.get("sampled") else ""
    return f"{row['mrays_s']:.2f}{star}"


def ceiling_for(row: dict, ceiling: dict | None) -> float | None:
    """The ceiling a row is compared with: for engine rows the raw rtcIntersect1 re-timed
    right before and after them (bench_intersect pairs them), else the run's one ceiling.
    """
    if row.get("paired_ceiling_mrays_s"):
        return row["paired_ceiling_mrays_s"]
    if ceiling and ceiling["kind"] == "trace" and ceiling["mrays_s"]:
        return ceiling["mrays_s"]
    return None


def fmt_ratio(row: dict | None, ceiling: dict | None) -> str:
    if row is None or row["kind"] != "trace":
        return "—"
    base = ceiling_for(row, ceiling)
    return f"{row['mrays_s'] / base:.2f}×" if base else "—"


def fmt_agree(row: dict | None) -> str:
    if row is None or row.get("agree_with_embree") is None:
        return "—"
    return f"{100 * row['agree_with_embree']:.2f}%"


def trace_lookup(
    rows: list[dict],
    workload: str,
    rays: str,
    peer: str,
    variant: str,
    mode: str = "closest",
    precision: str | None = None,
) -> dict | None:
    match = dict(workload=workload, rays=rays, peer=peer, variant=variant)
    hit = find(
        (r for r in rows if r["kind"] in ("trace", "unavailable")),
        **match,
        **({"mode": mode} if mode else {}),
        **({"precision": precision} if precision else {}),
    )
    if hit is None and mode:
        hit = find((r for r in rows if r["kind"] == "unavailable"), **match)
    return hit


# (label, peer, variant, mode, precision) of the headline table, top to bottom.
HEADLINE = [
    (
        "raw Embree `rtcIntersect1` (the ceiling)",
        "raw_embree",
        "rtcIntersect1",
        "closest",
        None,
    ),
    (
        "raw Embree `rtcIntersect16` packets",
        "raw_embree",
        "rtcIntersect16",
        "closest",
        None,
    ),
    (
        "raw Embree `rtcIntersect1`, ROBUST scene",
        "raw_embree",
        "rtcIntersect1 ROBUST",
        "closest",
        None,
    ),
    (
        "engine in-process, `fast`",
        "engine",
        "QueryEngine::intersect",
        "closest",
        "fast",
    ),
    (
        "engine in-process, `fast`, float32 records in, t/object/primitive out "
        "(`intersect_blocks`: the ceiling's own input and output)",
        "engine",
        "QueryEngine::intersect_blocks",
        "closest",
        "fast",
    ),
    (
        "engine in-process, `refined`",
        "engine",
        "QueryEngine::intersect",
        "closest",
        "refined",
    ),
    (
        "engine in-process, `exact`",
        "engine",
        "QueryEngine::intersect",
        "closest",
        "exact",
    ),
    (
        "allocating a fresh `std::vector<Hit>(n)` alone, no tracing (a floor for the engine)",
        "overhead",
        "fresh std::vector<Hit>",
        "closest",
        None,
    ),
    (
        "HTTP binary float32, whole ray set per request, `fast`, curl client",
        "http",
        "binary float32 curl",
        "closest",
        "fast",
    ),
    (
        "HTTP binary float32, whole ray set per request, `fast`, Python client",
        "http",
        "binary float32",
        "closest",
        "fast",
    ),
    ("HTTP JSON, 10k-ray requests, `fast`", "http", "JSON", "closest", "fast"),
    ("Open3D `cast_rays` (with mask shim)", "open3d", "cast_rays", "closest", None),
]


def headline_table(rows: list[dict], workload: str) -> list[str]:
    out = [
        "| path | coherent Mrays/s | × ceiling | incoherent Mrays/s | × ceiling | agrees with Embree |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    ceilings = {r: trace_lookup(rows, workload, r, *CEILING) for r in RAYS}
    for label, peer, variant, mode, precision in HEADLINE:
        cells = [label]
        agrees = []
        found = False
        for r in RAYS:
            row = trace_lookup(rows, workload, r, peer, variant, mode, precision)
            found = found or row is not None
            cells += [fmt_rate(row), fmt_ratio(row, ceilings[r])]
            if row is not None and row.get("agree_with_embree") is not None:
                agrees.append(fmt_agree(row))
        if not found:
            continue
        cells.append(" / ".join(agrees) if agrees else "—")
        out.append("| " + " | ".join(cells) + " |")
    return out


def modes_table(rows: list[dict], workload: str) -> list[str]:
    out = [
        "| mode | precision | coherent Mrays/s | × ceiling | incoherent Mrays/s | × ceiling "
        "| answered by |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    ceilings = {r: trace_lookup(rows, workload, r, *CEILING) for r in RAYS}
    for ref_variant, mode in (("rtcOccluded1", "any"), ("rtcOccluded16", "any")):
        cells = [f"`{mode}` (raw `{ref_variant}`)", "—"]
        for r in RAYS:
            row = trace_lookup(rows, workload, r, "raw_embree", ref_variant, mode)
            cells += [fmt_rate(row), fmt_ratio(row, ceilings[r])]
        out.append("| " + " | ".join(cells + ["—"]) + " |")
    for mode in ("closest", "any", "all", "count"):
        for precision in ("fast", "refined", "exact"):
            cells = [f"`{mode}`", f"`{precision}`"]
            answered = set()
            for r in RAYS:
                row = trace_lookup(
                    rows,
                    workload,
                    r,
                    "engine",
                    "QueryEngine::intersect",
                    mode,
                    precision,
                )
                cells += [fmt_rate(row), fmt_ratio(row, ceilings[r])]
                if row is not None and row.get("answered_precision"):
                    answered.add(row["answered_precision"])
            cells.append(", ".join(f"`{a}`" for a in sorted(answered)) or "—")
            out.append("| " + " | ".join(cells) + " |")
    return out


def build_table(rows: list[dict], workloads: list[str]) -> list[str]:
    variants: list[tuple[str, str]] = []
    for r in rows:
        if r["kind"] == "build" and (r["peer"], r["variant"]) not in variants:
            variants.append((r["peer"], r["variant"]))
    out = [
        "| what | " + " | ".join(workloads) + " |",
        "|---|" + "---:|" * len(workloads),
    ]
    for peer, variant in variants:
        cells = [f"{peer}: {variant}"]
        for w in workloads:
            row = find(
                (r for r in rows if r["kind"] == "build"),
                workload=w,
                peer=peer,
                variant=variant,
            )
            cells.append(
                "—" if row is None or row["ms"] is None else f"{row['ms']:.1f} ms"
            )
        out.append("| " + " | ".join(cells) + " |")
    return out


def unavailable_notes(rows: list[dict]) -> list[str]:
    seen = set()
    out = []
    for r in rows:
        if r["kind"] == "unavailable":
            key = (r["peer"], r["variant"], r["reason"])
            if key not in seen:
                seen.add(key)
                out.append(
                    f"- {r['peer']} {r['variant']}: not available ({r['reason']})."
                )
    return out


# --- targets of issue 4 --------------------------------------------------------------------------


def ratio(
    rows: list[dict],
    workload: str,
    rays: str,
    peer: str,
    variant: str,
    precision: str | None,
    against: tuple[str, str] = CEILING,
) -> float | None:
    row = trace_lookup(rows, workload, rays, peer, variant, "closest", precision)
    base = trace_lookup(rows, workload, rays, *against)
    if not row or not base or row["kind"] != "trace" or base["kind"] != "trace":
        return None
    if against == CEILING:
        denominator = ceiling_for(row, base)
        return row["mrays_s"] / denominator if denominator else None
    if row.get("paired_ceiling_mrays_s") and base.get("paired_ceiling_mrays_s"):
        # Two peers timed at different moments: compare their shares of the ceiling timed
        # around each, which cancels a change of load between them.
        return (row["mrays_s"] / row["paired_ceiling_mrays_s"]) / (
            base["mrays_s"] / base["paired_ceiling_mrays_s"]
        )
    return row["mrays_s"] / base["mrays_s"] if base["mrays_s"] else None


def checks_table(mesh: list[str], checks: list[tuple]) -> list[str]:
    """A targets table: one row per (label, value per workload, goal, unit), met when every
    measured value reaches the goal."""
    out = [
        "| target | " + " | ".join(mesh) + " | met |",
        "|---|" + "---:|" * len(mesh) + "---|",
    ]
    for label, values, goal, unit in checks:
        cells = [("—" if v is None else f"{v:.2f}{unit}") for v in values]
        known = [v for v in values if v is not None]
        met = (
            "—" if not known else ("yes" if all(v >= goal for v in known) else "**no**")
        )
        out.append(f"| {label} | " + " | ".join(cells) + f" | {met} |")
    return out


def targets_table_17(results: dict) -> list[str]:
    """Issue 17: the default precision against the peers (in-process, double rays in, full hits
    out, as QueryEngine::intersect answers)."""
    rows = results["rows"]
    mesh = [w for w in ("A", "B") if w in results["meta"]["workloads"]]
    open3d = ("open3d", "cast_rays")

    def ratios(rays: str, precision: str, against=CEILING) -> list[float | None]:
        who = ("engine", "QueryEngine::intersect", precision)
        return [ratio(rows, w, rays, *who, against=against) for w in mesh]

    checks = [
        (
            "`refined` ≥ 1.0× Open3D `cast_rays`, coherent",
            ratios("coherent", "refined", open3d),
            1.0,
            "×",
        ),
        (
            "`refined` ≥ 1.0× Open3D `cast_rays`, incoherent",
            ratios("incoherent", "refined", open3d),
            1.0,
            "×",
        ),
        (
            "`exact` ≥ 0.5× `rtcIntersect1`, coherent",
            ratios("coherent", "exact"),
            0.5,
            "×",
        ),
        (
            "`exact` ≥ 0.5× `rtcIntersect1`, incoherent",
            ratios("incoherent", "exact"),
            0.5,
            "×",
        ),
    ]
    out = checks_table(mesh, checks)
    # Memory: lower is better, so a row of its own (bench_intersect's --memory-probe rows).
    probes = {
        r["workload"]: r for r in rows if r.get("kind") == "memory" and r.get("triangles")
    }
    per_tri = [
        probes[w]["resident_refined_exact"] / probes[w]["triangles"] if w in probes else None
        for w in mesh
    ]
    known = [v for v in per_tri if v is not None]
    met = "—" if not known else ("yes" if all(v <= 130 for v in known) else "**no**")
    out.append(
        "| resident memory a triangle after `refined` and `exact` queries ≤ 130 B | "
        + " | ".join("—" if v is None else f"{v:.0f} B" for v in per_tri)
        + f" | {met} |"
    )
    # What the engine holds, the heap the build freed given back first (not the target's
    # measure, which is the process as it is: an explanation of the row above).
    held = [
        probes[w].get("held_refined_exact", 0) / probes[w]["triangles"]
        if w in probes and probes[w].get("held_refined_exact")
        else None
        for w in mesh
    ]
    if any(v is not None for v in held):
        out.append(
            "| the same with the heap the build freed given back first (malloc_trim) | "
            + " | ".join("—" if v is None else f"{v:.0f} B" for v in held)
            + " | (not the target's measure) |"
        )
    return out


POINT_SETS = {
    "A": "A, uniform",
    "A_shell": "A's shell (radii 0.99–1.01)",
    "B": "B, uniform",
    "B_shell": "B's shell (within 0.01)",
}
POINT_QUERIES = {"closest": "closest", "signed_distance": "signed distance"}


def point_ratio(row: dict | None, side: str, cpu: bool = False) -> float | None:
    """Open3D's seconds over `side`'s for one bench_points row: points/s against Open3D's."""
    if not row or not row.get(side) or not row.get("open3d"):
        return None
    k = 1 if cpu else 0
    return row["open3d"][k] / row[side][k] if row[side][k] > 0 else None


def points_section(results: dict) -> list[str]:
    """Issue 18: the point queries side by side, and the topology's share of a registration
    (bench_points --json)."""
    doc = results.get("points")
    if not doc:
        return ["Not measured in this run (a run from before bench_points joined it)."]
    if "unavailable" in doc:
        return [f"Not measured: {doc['unavailable']}."]
    out: list[str] = []
    rows = {(r["set"], r["query"]): r for r in doc.get("points", [])}
    if rows:
        sets = [k for k in POINT_SETS if any(key[0] == k for key in rows)]
        goals = {"closest": 1.5, "signed_distance": 1.0}
        checks = [
            (
                f"in-process {POINT_QUERIES[q]} ≥ {goal:.1f}× Open3D (points/s, wall)",
                [point_ratio(rows.get((k, q)), "ours") for k in sets],
                goal,
                "×",
            )
            for q, goal in goals.items()
        ]
        out += checks_table([POINT_SETS[k] for k in sets], checks)
        out += [
            "",
            "| points | query | in-process wall (CPU) | binary endpoint wall (server CPU) | "
            "Open3D wall (CPU) | in-process ÷ Open3D (CPU) | endpoint ÷ Open3D (CPU) |",
            "|---|---|---:|---:|---:|---:|---:|",
        ]

        def cell(pair) -> str:
            return "—" if not pair else f"{pair[0]:.3f} s ({pair[1]:.3f})"

        def ratio_cell(row, side) -> str:
            w, c = point_ratio(row, side), point_ratio(row, side, cpu=True)
            if w is None:
                return "—"
            # The server's CPU comes in 10 ms ticks: 0 on the smallest sets.
            return f"{w:.2f}× ({'—' if c is None else f'{c:.2f}×'})"

        for k in sets:
            for q in POINT_QUERIES:
                r = rows.get((k, q))
                if not r:
                    continue
                out.append(
                    f"| {POINT_SETS[k]}, {r['points']:,} | {POINT_QUERIES[q]} | "
                    f"{cell(r['ours'])} | {cell(r['endpoint'])} | {cell(r['open3d'])} | "
                    f"{ratio_cell(r, 'ours')} | {ratio_cell(r, 'endpoint')} |"
                )
        out.append("")
    reg = doc.get("registration")
    if reg:
        grow_w = reg["with"][0] / reg["without"][0] - 1
        grow_c = reg["with"][1] / reg["without"][1] - 1
        out.append(
            f"Registration of B ({reg['triangles']:,} triangles, binary PLY; medians of 3): "
            f"{reg['without'][0] * 1e3:.0f} ms without the topology (parse, validate, Embree "
            f"BVH), {reg['with'][0] * 1e3:.0f} ms with it (parse, `QueryEngine::build`): "
            f"**{grow_w:+.0%} wall ({grow_c:+.0%} CPU)** against a target of ~+30%; the "
            f"topology alone {reg['topology'][0] * 1e3:.0f} ms, the BVH "
            f"{reg['bvh'][0] * 1e3:.0f} ms."
        )
        out.append("")
    check = doc.get("sphere_check")
    if check and not check["worst"] <= check["tolerance"]:
        out.append(
            f"**bench_points' own check failed**: a signed distance on A is {check['worst']:.2e} "
            f"from the sphere's, beyond the icosphere's {check['tolerance']:.2e}."
        )
        out.append("")
    if doc.get("exit_code"):
        out.append(f"bench_points exited with {doc['exit_code']}.")
        out.append("")
    out.append(POINTS_NOTE)
    return out


def targets_table(results: dict) -> list[str]:
    rows = results["rows"]
    mesh = [w for w in ("A", "B") if w in results["meta"]["workloads"]]
    engine = ("engine", "QueryEngine::intersect", "fast")
    records = ("engine", "QueryEngine::intersect_blocks", "fast")
    # The HTTP targets are judged on the curl client (a C client, as a heavy user would run);
    # the Python client's row is in the tables.
    binary = ("http", "binary float32 curl", "fast")

    def ratios(rays: str, who: tuple, against=CEILING) -> list[float | None]:
        return [ratio(rows, w, rays, *who, against=against) for w in mesh]

    def json_rates() -> list[float | None]:
        out = []
        for w in mesh:
            rates = [
                trace_lookup(rows, w, r, "http", "JSON", "closest", "fast")
                for r in RAYS
            ]
            rates = [x["mrays_s"] for x in rates if x and x["kind"] == "trace"]
            out.append(min(rates) if rates else None)
        return out

    load = results.get("small_requests") or {}
    checks = [
        (
            "engine in-process ≥ 1.5× `rtcIntersect1`, coherent: `QueryEngine::intersect` "
            "(double rays in, full hits out)",
            ratios("coherent", engine),
            1.5,
            "×",
        ),
        (
            "… the same on float32 records, `QueryEngine::intersect_blocks` (the ceiling's "
            "input and output)",
            ratios("coherent", records),
            1.5,
            "×",
        ),
        (
            "engine in-process ≥ 1.0× `rtcIntersect1`, incoherent: `QueryEngine::intersect`",
            ratios("incoherent", engine),
            1.0,
            "×",
        ),
        (
            "… the same on float32 records, `QueryEngine::intersect_blocks`",
            ratios("incoherent", records),
            1.0,
            "×",
        ),
        (
            "binary HTTP ≥ 0.5× `rtcIntersect1`, incoherent",
            ratios("incoherent", binary),
            0.5,
            "×",
        ),
        (
            "binary HTTP ≥ 2× Open3D, coherent",
            ratios("coherent", binary, against=("open3d", "cast_rays")),
            2.0,
            "×",
        ),
        (
            "JSON ≥ 0.5 Mrays/s end to end (slower ray set)",
            json_rates(),
            0.5,
            " Mrays/s",
        ),
    ]
    out = checks_table(mesh, checks)
    req_s = load.get("req_s")
    cells = [f"{req_s:,.0f} req/s" if req_s is not None else "—"] + [""] * (
        len(mesh) - 1
    )
    met = "—" if req_s is None else ("yes" if req_s >= 20000 else "**no**")
    out.append(
        "| ≥ 20,000 one-ray requests/s, 16 keep-alive connections (on A) | "
        + " | ".join(cells)
        + f" | {met} |"
    )
    return out


# Why issue 17's targets stand where they do (docs/numerics.md, the refined bullet, has the
# measurements behind it).
ISSUE_17_NOTE = (
    "`refined` now traces once: its triangles are widened in their planes beyond what float "
    "rounding can move a ray, and a hit filter decides every float candidate in double, so a "
    "float miss no longer needs the exact BVH (docs/numerics.md). Since the night of "
    "2026-12-06 the filter decides a packet's lanes on one triangle four at a time in AVX2 "
    "(bit for bit as one at a time), which took A's camera rays past Open3D; B's have stayed "
    "just below it (0.92-0.95× Open3D in the runs of 2026-12-07 and 08). On random rays "
    "a call has one lane, and what still separates refined from Open3D, which is raw float "
    "Embree, is that double decision of each candidate and of the answer: the double "
    "triangle's read alone was 12% of refined's time there (perf, 1M rays on A), a cache miss "
    "a candidate; ROBUST traversal costs 10-15%. Since 2026-12-07 a packet of random rays "
    "defers each lane's first decision to after the traversal, where the deferred lanes' "
    "triangles are fetched together and their cache misses overlap: B's random rays went from "
    "0.53-0.57× to 0.60-0.65× `rtcIntersect1` in paired runs, A's (whose triangles fit the "
    "cache) did not move. On B Open3D runs at 0.8-0.95× raw Embree, and refined's ROBUST "
    "traversal alone at 0.85-0.98×; its own work (the clipped ray's set-up, the double "
    "decision, the answer) makes most of the rest (one thread, 1M random rays: 3.0 Mrays/s "
    "against `fast`'s 4.9; docs/numerics.md). In the run of 2026-12-08 Open3D read 0.87× (A) "
    "and 0.95× (B) `rtcIntersect1` on random rays, above the 0.80× and 0.86× of the ROBUST "
    "traversal that refined's float pass rides on: there refined would miss the target even "
    "with its double decisions free. "
    "`exact` decides every candidate in double; "
    "since 2026-12-06 its BVH is our own (eight-wide, a leaf's primitive in its parent's child "
    "code) instead of Embree's user geometry, with its bottom nodes full and quantized since "
    "that evening: 70-80 B a triangle less in all, and its speed within about 10% either way of "
    "Embree's in paired runs (docs/numerics.md). Since 2026-12-07 its walk passes over a "
    "triangle whose edge functions alone settle a miss (the first stage of Woop's test, in AVX "
    "in the walk: 1.9 of A's 2.76 candidates a camera ray), and neighbouring camera rays walk "
    "it eight at a time (each child's box against every lane at once), which took the coherent "
    "rows past 0.5×; random rays walk alone, and their time is the nodes' and triangles' cache "
    "misses and the double decision of the answer. Since the morning of 2026-12-07 a walk that "
    "meets several children of a node prefetches them, which took B's random rays, whose walk "
    "reads ~51 MB, more than the cache, from 0.48-0.49× to 0.55-0.58× in paired runs; A's "
    "random rows, whose ~4 MB fit, have read 0.41-0.54× from run to run with or without it "
    "(docs/numerics.md). Since the afternoon of 2026-12-07 the release build links with LTO "
    "(CMakeLists.txt, docs/testing.md): three alternating pairs of `bench_intersect "
    "--workloads A --modes closest` without and with it put `exact`'s camera rays at 7.55-7.65 "
    "→ 8.19-8.34 Mrays/s, `fast` and `refined` unchanged within the host's noise. The host "
    "moves every row: raw `rtcIntersect16` on A's camera rays has read from 49.8 to 65.3 "
    "Mrays/s in the runs of 2026-12-06 to 08 with the same Embree, and the ratios against "
    "`rtcIntersect1` move with it (`fast`'s coherent row on A from 2.42× to 3.21×, with the "
    "same code on that path). "
    "The memory row is the resident growth of a process of its own (`bench_intersect "
    "--memory-probe W`) from before the scene is made to after one `refined` and one `exact` "
    "query: the scene's vertices and indices (~24 B a triangle), the native BVH over the "
    "widened triangles (~66 B; the float vertices it was built from are given back after the "
    "build, since its leaves hold copies: embree/build_buffer.h), and exact's BVH (26-27 B, its "
    "bottom nodes quantized to a byte a plane; docs/numerics.md); "
    "`fast`'s BVH, built on a first `fast` query, is not in it. Since 2026-12-07 the builds "
    "leave no freed heap behind on A (the topology's edges reserved to their count, exact's "
    "build scratch in mappings of its own: engine/mapped_allocator.h), so the untrimmed row "
    "reads what the trimmed one does."
)

POINTS_NOTE = (
    "Measured by `bench_points` (its own output has more rows: the given order, occupancy, "
    "the winding-number path on B minus one triangle); docs/points.md has the history and "
    "the reasons. Points are 1,048,576 a set in the full run, rounded to float so that both "
    "peers get the same ones; A is the 81,920-triangle icosphere, B the 1,024,000-triangle "
    "field of 200 icospheres (closed: parity signs). On A each side is the median of 3 calls "
    "after a warm-up; on B one call each (Open3D takes tens of seconds a call there). The "
    "binary endpoint is `POST /v1/scenes/{id}/points?dtype=float32` on loopback, timed to the "
    "answer's last byte. The accuracy of the same queries against a quad-precision reference, "
    "with Open3D's, is in docs/accuracy.md (`bench/accuracy_points.py`)."
)

# --- the document --------------------------------------------------------------------------------


def load_banner(m: dict, meta: dict) -> list[str]:
    """A warning above the figures when other work competed for the cores."""
    busiest = max(m["loadavg_start"][0], m["loadavg_end"][0])
    if busiest <= m["cores"]:
        return []
    used = meta.get("cores_used")
    share = (
        f" `bench_intersect` had {used:.2f} of its {meta['threads']} threads' worth of CPU "
        "on average (CPU time / wall time)."
        if used is not None
        else ""
    )
    return [
        f"**Measured on a busy machine**: the 1-minute load average was "
        f"{m['loadavg_start'][0]:.1f} at the start and {m['loadavg_end'][0]:.1f} at the end "
        f"on {m['cores']} cores (other engineers' compiles).{share} Absolute figures are several times "
        "below the ceilings in PERFORMANCE.md and move between runs; compare paths by their "
        "ratios, and re-run on a quiet machine (`bench/run_all.py --wait-quiet 10`) before "
        "reading much into any single figure.",
        "",
    ]


def engine_status(rows: list[dict]) -> str:
    answered = {
        r.get("answered_precision")
        for r in rows
        if r["kind"] == "trace" and r["peer"] == "engine" and r["precision"] == "fast"
    }
    sampled = any(r.get("sampled") for r in rows if r["kind"] == "trace")
    if answered == {"exact"}:
        text = (
            "**Measured before Embree acceleration landed in the engine**: every engine request, "
            "whatever precision it asked for, was answered by the exact double-precision brute "
            "force path (`answered by` = `exact`). Engine and HTTP figures are those of that "
            "path, not of the Embree-backed one; re-run `bench/run_all.py` once it lands."
        )
    else:
        text = (
            "Measured with the Embree-backed engine (engine requests for `fast` were answered "
            "by: "
            + ", ".join(f"`{a}`" for a in sorted(a for a in answered if a))
            + ")."
        )
    if sampled:
        text += (
            " Figures marked \\* were measured on an evenly strided sample of the rays: "
            "JSON always (at most 200,000 rays per set), other paths when the whole set "
            "would not fit the time budget (see the notes)."
        )
    return text


HOW_TO_RUN = """\
```sh
scripts/setup.sh --bench                              # once, as root: Open3D, NumPy, matplotlib, POV-Ray
cmake --preset release && cmake --build build/release -j2
bench/run_all.py                                      # the full run; rewrites this file
bench/run_all.py --quick                              # small sizes, ~1 min; writes build/release/bench/benchmarks-quick.md
bench/run_all.py --wait-quiet 10                      # first wait (up to 10 min) for the load average to fall below 1
bench/run_all.py --render-only build/release/bench/data-full/results.json   # re-render, measure nothing
ctest --test-dir build/release -R bench_smoke         # < 1 s: the intersect bench on tiny sizes
ctest --test-dir build/release -R bench_probe_smoke   # < 1 s: the probe's batches against single rays
```
`run_all.py` builds nothing and must run under Debian's `/usr/bin/python3` (its shebang). Pieces
run alone: `build/release/bench/bench_intersect [--quick|--smoke] [--workloads AB] [--json F]
[--data-dir D]` (raw Embree and the engine in-process);
`LD_PRELOAD=build/release/bench/libembree_mask_shim.so bench/peers/open3d_peer.py --data-dir D
--workload A` (Open3D, on files `bench_intersect --data-dir D` wrote);
`build/release/bench/bench_http_load --port P --path /v1/scenes/ID/intersect --body-file F`
(small requests against a running server);
`build/release/bench/bench_probe [--workload A|B|C] [--rays camera|random] [--precision P]
[--mode closest|any] [--repeats N] [--threads N] [--quick|--smoke] [--check]` (one ray set
through one precision, one thread by default: the best and median of N batches, and the hits,
sum of t and a hash of the answers to compare two builds' answers by; `--check` asks every ray
again on its own and fails at `exact` on any difference. A change to one path is judged by two builds' probes run in turn: on this host a
figure moves by ±20% from minute to minute, and bench_intersect's rows share both cores).
Every intermediate file, including `results.json`
with every figure, goes to `build/release/bench/data-<preset>/` and is never committed."""

COLUMNS = """\
- **Mrays/s**: rays answered per second of wall-clock time, median of several runs after a
  warm-up (raw Embree: 5; engine and HTTP: 3 when the full set fits the time budget; Open3D: 3).
  For HTTP the clock covers sending the request, the server's work and receiving the whole
  response on loopback; bodies are encoded before and responses decoded after the clock.
- **× ceiling**: that figure divided by raw Embree `rtcIntersect1` on the same workload and the
  same rays in the same run (2 threads, TBB `parallel_for`, default scene flags, `MEDIUM` build).
  The machine is shared, so every ratio is paired: engine rows are divided by `rtcIntersect1`
  re-timed right before and right after that very measurement (the mean of the two), HTTP and
  Open3D rows by `rtcIntersect1` re-timed (`bench_intersect --ceiling-only`) right before and
  after that peer ran on that workload; so both figures of a ratio are taken under the same
  load, and a ratio may differ from dividing the two Mrays/s figures shown. Raw Embree rows are
  divided by the ceiling row of the table. "binary HTTP ≥ 2× Open3D" compares the two peers'
  paired ratios.
- **agrees with Embree**: share of the measured rays whose closest hit has the same hit/miss
  decision as raw Embree's `rtcIntersect1` and the same object and primitive, or the same `t`
  within 1e-4 relative (a neighbour across a shared edge); coherent / incoherent.
- **answered by**: the precision path the engine reports having used (`QueryResult::precision`,
  the `precision` field / `X-Precision` header over HTTP).
- **raw `rtcIntersect16`**: 16-ray packets; the coherent rays come in 4×4 pixel tiles, so 16
  consecutive rays are a tile. `rtcOccluded1/16` are the ceilings for `any`.
- **\\***: measured on an evenly strided sample of the rays (JSON: always; see the notes).
- Workloads: **A** icosphere level 6; **B** 200 icospheres of level 4 with random centres and
  radii, merged into one mesh; **C** 1000 analytic spheres (Embree `SPHERE_POINT` in raw Embree).
  Coherent rays: a pinhole camera (1024×1024 in the full run, 45° vertical field of view) whose
  image height the bounding sphere just fills; incoherent rays (1,048,576 in the full run):
  origins uniform in the bounds scaled 1.5× about their centre, directions uniform on the
  sphere. Fixed seeds. `--quick` shrinks every workload and ray set (see the headings)."""


def rows_of(results: dict, peer: str) -> list[dict]:
    return [r for r in results["rows"] if r.get("peer") == peer]


def notes(results: dict) -> list[str]:
    m = results["machine"]
    out = [
        f"- Noise: the machine is shared; load average {m['loadavg_start'][0]:.2f} at the start "
        f"and {m['loadavg_end'][0]:.2f} at the end of this run (other engineers compile on it). "
        "Ratios within one run are more trustworthy than absolute figures; PERFORMANCE.md's "
        "ceilings (29.2 / 18.6 Mrays/s on A) were measured on a quieter machine.",
        "- Open3D 0.16.1 from Debian leaves the Embree ray mask at 0 and Debian's Embree is built "
        "with ray masks, so out of the box every ray misses. Its figures here are taken with "
        "`bench/peers/embree_mask_shim.c` preloaded: it wraps the only two trace calls Open3D "
        "makes (`rtcIntersect1M`, `rtcOccluded1M`, per `nm -D`), sets `mask = 0xFFFFFFFF` on "
        "each ray and forwards to Embree; one store per ray, nothing else changes.",
        "- Time budgets: each engine measurement gets ~1.5 s and each HTTP one ~6 s. A path too "
        "slow to trace the whole set within that is measured on an evenly strided sample "
        "(marked \\*), which loses the coherence of camera rays; that only matters once the path "
        "is fast enough to trace every ray, and then the whole set is traced.",
        "- HTTP JSON sends batches of 10,000 rays (up to 200,000 rays per ray set) asking for "
        "`fields: [t, object, primitive]`; the binary form sends the whole set in one request. "
        "The Python client (`http.client`, one keep-alive connection, TCP_NODELAY) shares the "
        "two cores with the server. Small requests come from `bench_http_load` (C++, cpp-httplib, "
        "16 threads), because a Python client would measure its own GIL.",
        "- Build times: raw Embree is `rtcCommitScene` alone; the engine is "
        "`QueryEngine::build` (validation and whatever acceleration it builds); the server's is "
        "the whole `POST /v1/scenes` with a PLY body (upload, parse, hash, build); Open3D's is "
        "its first one-ray query, which commits its scene.",
    ]
    floor = [
        r
        for r in rows_of(results, "overhead")
        if r["kind"] == "trace" and r["total_rays"] >= 1 << 20
    ]
    if floor:
        r = floor[0]
        out.append(
            f"- The *fresh `std::vector<Hit>(n)`* row times only allocating and zero-filling "
            f"an answer of the shape `QueryEngine::intersect` returns ({r['bytes'] / 2**20:.0f} "
            f"MB for {r['total_rays']:,} rays): fresh pages cost their first touch on this "
            f"machine, which caps any path that returns a new `QueryResult` per call at about "
            f"{r['mrays_s']:.1f} Mrays/s here, however fast it traces."
        )
    if m.get("dirty"):
        out.append(
            f"- The working tree at commit {m['commit']} had uncommitted changes (other "
            "engineers' work in progress) when this ran; the binaries are what was built "
            "from it."
        )
    if results["meta"].get("worst_agreement", 1.0) < 0.99:
        out.append(
            f"- The engine disagreed with Embree on more than 1% of some ray set (worst "
            f"agreement {100 * results['meta']['worst_agreement']:.2f}%)."
        )
    return out


def render(results: dict, accuracy: str) -> str:
    rows = results["rows"]
    meta = results["meta"]
    m = results["machine"]
    workloads = list(meta["workloads"].keys())
    date = meta["date"]
    lines = [
        "# Benchmarks",
        "",
        f"Generated by `bench/run_all.py` (preset `{results['preset']}`) on {date} in "
        f"{m['run_seconds'] / 60:.1f} minutes, at commit `{m['commit']}`"
        f"{' (with uncommitted changes in the tree)' if m.get('dirty') else ''}. "
        "The figures below are rewritten by each run; the prose lives in `bench/report_md.py`.",
        "",
        engine_status(rows),
        "",
        *load_banner(m, meta),
        "## How to run",
        "",
        HOW_TO_RUN,
        "",
        "## Machine",
        "",
        f"{m['cpu']}, {m['cores']} cores (all benches use both: TBB limited to "
        f"{meta['threads']} threads), Linux {m['kernel']}, Embree {meta['embree']} and "
        f"Open3D {results.get('open3d', {}).get('version', '—')} from Debian 12.",
        "",
        "## Targets of issue 4",
        "",
        *targets_table(results),
        "",
        '"Binary HTTP ≥ 2× Open3D on coherent rays" is beyond what this machine can do with '
        "the contract's 32-byte records: it asks for 2 × 12–17 Mrays/s, while a 1M-ray float32 "
        "request against a scene its rays never reach (no tracing at all: 32 MB up and 32 MB "
        "down over loopback, the checks, decoding and encoding) takes 0.072 s with curl, "
        "≈ 14.5 Mrays/s (measured 2026-12-01; PERFORMANCE.md's bare loopback figure is "
        "≈ 11 Mrays/s). Camera-ray requests on A and B now take that same 0.072 s: tracing is "
        "entirely hidden behind the transport. Binary batches are traced while they arrive and "
        "answered chunk by chunk (docs/api.md); on random rays the answer's writer traces "
        "later chunks while a TBB task finishes the next one (two cores give TBB one worker "
        "thread), which took A from 0.121 to 0.097 s and B from 0.23 to 0.143 s per 1M-ray "
        "request. The HTTP targets are judged on the curl client; the Python client "
        "(`http.client`) is slower (it copies a 32 MB answer several times while sharing the "
        "cores). "
        "The engine's `fast` traces a BVH of its own without Embree's ROBUST flag, as raw "
        "`rtcIntersect1` does (`refined` and `exact` keep the watertight one; docs/numerics.md). "
        "The engine is measured two ways: `QueryEngine::intersect` takes 64-byte double rays "
        "and returns 72-byte hits with normals and error bounds, which for 1M rays is 136 MB "
        "of memory traffic against the ceiling's 44 MB; `QueryEngine::intersect_blocks` reads "
        "the ceiling's own 32-byte float records and writes its t, object and primitive, "
        "through per-thread block buffers that stay in cache. The server's binary path calls "
        "the latter.",
        "",
        "## Targets of issue 17",
        "",
        *targets_table_17(results),
        "",
        ISSUE_17_NOTE,
        "",
        "## Targets of issue 18: point queries",
        "",
        *points_section(results),
        "",
        "## Closest hit on each whole ray set (1M rays in the full run)",
        "",
    ]
    for w in workloads:
        info = meta["workloads"][w]
        rays = info.get("rays", {})
        lines += [
            f"### {w}: {info['description']} "
            f"({rays.get('coherent', 0):,} coherent, {rays.get('incoherent', 0):,} "
            "incoherent rays)",
            "",
            *headline_table(rows, w),
            "",
        ]
    lines += ["## Every mode and precision, engine in-process", ""]
    for w in workloads:
        lines += [
            f"### {w}: {meta['workloads'][w]['description']}",
            "",
            *modes_table(rows, w),
            "",
        ]
    lines += ["## Build times", "", *build_table(rows, workloads), ""]
    load = results.get("small_requests") or {}
    lines += ["## Small requests", ""]
    if "req_s" in load:
        lines.append(
            f"One-ray JSON `closest` requests on A from {load['connections']} keep-alive "
            f"connections for {load['seconds']:.1f} s: **{load['req_s']:,.0f} requests/s** "
            f"({load['ok']:,} answered 200, {load['errors']:,} otherwise: "
            f"{json_statuses(load['statuses'])})"
            + (
                f", the median of {len(load['runs'])} runs: "
                + ", ".join(f"{r:,.0f}" for r in load["runs"])
                + " requests/s."
                if load.get("runs")
                else "."
            )
        )
    else:
        lines.append(f"Not measured ({load.get('error', 'no server run')}).")
    lines += ["", "## Open3D and the Embree ray mask", ""]
    check = results.get("open3d", {}).get("without_shim")
    if check:
        lines.append(
            f"Without the shim, Open3D found {check['hits']:,} hits on the first "
            f"{check['rays']:,} coherent rays of A, where raw Embree finds {check['ref_hits']:,}. "
            "With it, its hits agree with raw Embree's as the tables show (column *agrees with "
            "Embree*)."
        )
    else:
        lines.append("Open3D was not run.")
    lines += ["", "## Run time against error (issue 6)", ""]
    lines.append(accuracy.strip())
    unavail = unavailable_notes(rows)
    lines += [
        "",
        "## What the columns mean",
        "",
        COLUMNS,
        "",
        "## Notes",
        "",
        *notes(results),
        *unavail,
        "",
    ]
    return "\n".join(lines)


def json_statuses(statuses: dict) -> str:
    def name(k: str) -> str:
        return "transport error (closed or reset)" if k == "-1" else f"HTTP {k}"

    return ", ".join(f"{name(k)}: {v:,}" for k, v in statuses.items()) or "none"
