#pragma once
// RequestHead: the request line and header block of one HTTP/1.1 request, checked before
// cpp-httplib parses it. cpp-httplib 0.11.4 reads Content-Length with strtoull, so "-5" or a
// 23-digit value becomes a length near 2^64 that it then tries to skip, holding the connection;
// it takes the first of two different Content-Length headers; and it reads a body over the
// limit to its end before saying 413. RFC 9112 §6.3 makes each of these a framing error that a
// server must answer with 400 and a closed connection (a request-smuggling vector otherwise).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "server/api_error.h"

namespace raycastd::server {

/// What the head of a request may be.
struct HeadLimits {
    std::size_t max_head_bytes = 16u << 10;   ///< request line + headers (431 above)
    std::size_t max_target_bytes = 8u << 10;  ///< the request target (414 above)
    std::uint64_t max_body_bytes = 512u << 20;
};

/// Why a head is refused: the HTTP status, the API's code and a message (RFC 9112 §6.3).
struct HeadError {
    int status = 400;
    ErrorCode code = ErrorCode::invalid_request;  ///< invalid_request or too_large
    std::string message;
};

/// A checked request head.
struct RequestHead {
    std::size_t head_bytes = 0;  ///< bytes up to and including the blank line
    std::string method;
    std::string target;
    std::uint64_t content_length = 0;  ///< 0 when absent
    bool chunked = false;              ///< Transfer-Encoding: chunked
    /// The head as cpp-httplib is to read it, when that differs from the bytes received
    /// (nullopt: as received). Every line ends in CRLF (cpp-httplib 0.11 takes a bare LF for
    /// no line end and answered such a head a bare 400); Range headers are dropped, since
    /// raycastd serves no partial content and cpp-httplib cut or multiplied any answer by them
    /// (a 200 cut short, one copy of the answer per range); a form-urlencoded Content-Type
    /// reads text/plain (the library caps form bodies at 8 KiB; no endpoint takes a form); a
    /// Content-Encoding reads lower case, as the library compares it.
    std::optional<std::string> rewritten;
};

/// The longest header line cpp-httplib 0.11 reads, terminator included (its
/// CPPHTTPLIB_HEADER_MAX_LENGTH); a longer one is refused here with 431.
constexpr std::size_t kMaxHeaderLineBytes = 8192;

/// The length of the head at the start of `bytes` (through its blank line), or nullopt when
/// it is not complete yet. Accepts bare LF line ends as RFC 9112 §2.2 allows.
std::optional<std::size_t> find_head_end(std::string_view bytes);

/// Why a head of more than limits.max_head_bytes is refused: 414 when its request line alone
/// (complete or not) is longer than a request line with the longest target allowed, else 431.
HeadError oversized_head(std::string_view bytes, const HeadLimits& limits);

/// Checks a complete head (`bytes` starts with it; its length is find_head_end's). Either the
/// RequestHead or the HeadError to answer.
struct HeadCheck {
    std::optional<RequestHead> head;
    HeadError error;
};
HeadCheck check_request_head(std::string_view bytes, std::size_t head_bytes,
                             const HeadLimits& limits);

}  // namespace raycastd::server
