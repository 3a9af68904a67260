"""What the contract (../shared/API.md, docs/api.md) says each fault and hostile input must get.

The ONE place where expected answers are written down. Each entry: the HTTP statuses accepted,
the error codes accepted (None: any, or no JSON body needed), and where the contract says so.
A check compares what the server answered with its entry here, and its failure message names both.
"""

# status sets
OK = {200}
CREATED = {201}
BAD = {400}

EXPECTED = {
    # --- faults ---------------------------------------------------------------------------
    # A registration on a full data dir: nothing registered, 507 (API.md error table).
    "faults.full_disk.register_when_full": ({507}, {"insufficient_storage"},
                                            "docs/api.md: 507 insufficient_storage, the data dir is full"),
    # After a DELETE has freed room, registering works again.
    "faults.full_disk.register_after_delete": ({201}, None, "space freed by a DELETE"),
    "faults.full_disk.delete_when_full": ({200}, None, "a DELETE frees space, it needs none"),
    # A read-only data dir: nothing registered or deleted, 507.
    "faults.read_only.register": ({507}, {"insufficient_storage"},
                                  "docs/api.md: 507, the data dir is read-only: nothing was registered"),
    "faults.read_only.delete": ({507}, {"insufficient_storage"},
                                "docs/api.md: 507, the data dir is read-only: nothing was deleted"),
    # --- hostile inputs (class -> statuses, codes) ------------------------------------------
    "hostile.deep_json": (BAD, {"invalid_request", "bad_json"},
                          "100,000 levels of nesting: a bad request never crashes the server"),
    "hostile.nan_inf_literal": (BAD, {"bad_json"},
                                "docs/api.md: JSON cannot carry NaN or Inf: such a body is bad_json"),
    "hostile.overflowing_number": (BAD, {"bad_json"},
                                   "docs/api.md: a number that overflows a double (1e999) is bad_json"),
    "hostile.huge_finite": ({200, 201, 400}, {"invalid_scene", "invalid_ray", None},
                            "finite but huge (1e308): an answer or a 400, never a 5xx"),
    "hostile.binary_nan_inf": (BAD, {"invalid_ray"},
                               "docs/api.md: in the binary form a NaN/Inf/zero direction is invalid_ray"),
    "hostile.garbage_model": ({400, 422}, {"model_load_failed", "unsupported_format", "bad_json"},
                              "random bytes as a model: 422 model_load_failed (400 if not a model at all)"),
    "hostile.truncated_glb": ({422}, {"model_load_failed"},
                              "docs/api.md: a truncated model is 422 model_load_failed"),
    "hostile.truncated_glb_header": ({400, 422}, {"model_load_failed", "unsupported_format", "bad_json"},
                                     "fewer than 12 bytes of a GLB: not even a header"),
    "hostile.bad_json_misc": (BAD, {"bad_json", "invalid_request", "invalid_scene", "invalid_ray",
                                    "unsupported_format"},
                              "not JSON, empty, truncated, wrong top-level type"),
    "hostile.mutated_docs": ({200, 201, 400, 404, 413, 422}, None,
                             "valid documents with random bytes changed: any answer but a 5xx"),
    "hostile.long_url": ({414}, {"too_large"}, "docs/api.md: 414 too_large (the URL), as JSON"),
    "hostile.content_length_negative": ({400}, None, "Content-Length: -5, answered within 2 s"),
    "hostile.content_length_23_digits": ({400, 413}, None,
                                         "a 23-digit Content-Length, answered within 2 s"),
    "hostile.content_length_twice": ({400}, None,
                                     "two different Content-Length headers (RFC 9112 6.3): 400"),
    "hostile.idle_sockets": (OK, None,
                             "64 sockets holding a partial head: a fresh GET /v1/health answered within 2 s"),
    "hostile.half_close": (OK, None, "a client that shuts down its sending side gets its answer"),
    "hostile.form_urlencoded_scene": ({200, 201}, None,
                                      "docs/api.md: curl -d's form content type is told by the bytes"),
}

# Time limits, seconds.
ANSWER_WITHIN = 2.0  # hostile headers and idle sockets
RESTART_WITHIN = 20.0


def expected(name):
    return EXPECTED[name]


def describe(name):
    statuses, codes, why = EXPECTED[name]
    s = "/".join(str(x) for x in sorted(statuses))
    if codes:
        s += " " + "|".join(sorted(c for c in codes if c))
    return "%s (%s)" % (s, why)


def matches(name, status, code):
    statuses, codes, _ = EXPECTED[name]
    if status not in statuses:
        return False
    if codes is None or status < 400:
        return True
    return code in codes or (None in codes and code is None)
