#pragma once
// Reusable buffers for intersect requests. A 1M-ray batch moves 32-64 MB each way and answers
// into ~72 MB of hits; fresh buffers of that size cost more in page faults than tracing the
// rays (measured at ~2.5 ms per MB). They used to be thread_local, which with one worker
// thread per keep-alive client (app.cpp) would let every worker pin its own few hundred MB.
// A small pool keeps at most kRetained sets, whichever requests used them last; more sets
// exist only while more requests are in flight or their answers are still being written to
// slow readers (a binary answer streams from its set).

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "engine/query/query_result.h"
#include "server/schema/query_doc.h"

namespace raycastd::server {

/// One chunk of a streamed binary batch (server/intersect/binary_stream.h): its encoded answer (its
/// rays are decoded from the body a block at a time as they are traced).
struct StreamChunk {
    std::string out;  ///< the chunk's encoded answer
};

struct Scratch {
    std::string body;               ///< the request body, streamed in
    std::vector<engine::Ray> rays;  ///< decoded binary rays
    IntersectRequest parsed;        ///< the JSON fast path's parse
    engine::QueryResult result;     ///< the engine's answers
    std::string out;                ///< an encoded binary answer
    /// A streamed batch's chunks, kept for the next one (unique_ptr: a chunk stays where it is
    /// while the list grows under running chunks).
    std::vector<std::unique_ptr<StreamChunk>> chunks;
    /// Freed, not pooled, when the last pointer goes: set by a request whose work was
    /// cancelled (request_cancel.h), so that an abandoned batch hands its memory back.
    bool discard = false;
};

/// A Scratch from the pool (or a new one); it returns to the pool when the last copy of the
/// pointer goes, e.g. after a streamed response that captured it has been written.
std::shared_ptr<Scratch> acquire_scratch();

}  // namespace raycastd::server
