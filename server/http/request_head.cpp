#include "server/http/request_head.h"

#include <algorithm>
#include <cctype>

namespace raycastd::server {

namespace {

/// tchar of RFC 9110 §5.6.2: the characters of a method or a header name.
bool is_tchar(char c) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u))
        return true;
    return std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

bool is_token(std::string_view s) {
    return !s.empty() && std::all_of(s.begin(), s.end(), is_tchar);
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
        s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
        s.remove_suffix(1);
    return s;
}

bool iequals(std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
               return std::tolower(static_cast<unsigned char>(x)) ==
                      std::tolower(static_cast<unsigned char>(y));
           });
}

HeadCheck refuse(int status, ErrorCode code, std::string message) {
    HeadCheck c;
    c.error = HeadError{status, code, std::move(message)};
    return c;
}

HeadCheck bad(std::string message) {
    return refuse(400, ErrorCode::invalid_request, "malformed HTTP request: " + std::move(message));
}

}  // namespace

std::optional<std::size_t> find_head_end(std::string_view bytes) {
    // The head ends at the first empty line: LF LF or LF CR LF (a CR before the first LF
    // belongs to the previous line).
    for (std::size_t i = bytes.find('\n'); i != std::string_view::npos;
         i = bytes.find('\n', i + 1)) {
        if (i + 1 < bytes.size() && bytes[i + 1] == '\n')
            return i + 2;
        if (i + 2 < bytes.size() && bytes[i + 1] == '\r' && bytes[i + 2] == '\n')
            return i + 3;
    }
    return std::nullopt;
}

HeadError oversized_head(std::string_view bytes, const HeadLimits& limits) {
    // A request line is METHOD SP TARGET SP HTTP/1.1: a few dozen bytes besides the target.
    constexpr std::size_t kLineOverhead = 64;
    const std::size_t line = std::min(bytes.find('\n'), bytes.size());
    if (line > limits.max_target_bytes + kLineOverhead) {
        return HeadError{
            414, ErrorCode::too_large,
            "the URL is over the limit of " + std::to_string(limits.max_target_bytes) + " bytes"};
    }
    return HeadError{431, ErrorCode::too_large,
                     "the request line and headers are over " +
                         std::to_string(limits.max_head_bytes) + " bytes"};
}

HeadCheck check_request_head(std::string_view bytes, std::size_t head_bytes,
                             const HeadLimits& limits) {
    if (head_bytes > limits.max_head_bytes) {
        HeadCheck c;
        c.error = oversized_head(bytes, limits);
        return c;
    }
    RequestHead head;
    head.head_bytes = head_bytes;
    const std::string_view all = bytes.substr(0, head_bytes);

    std::size_t pos = 0;
    const auto next_line = [&](std::string_view& line) {
        const std::size_t lf = all.find('\n', pos);
        if (lf == std::string_view::npos)
            return false;
        line = all.substr(pos, lf - pos);
        if (!line.empty() && line.back() == '\r')
            line.remove_suffix(1);
        pos = lf + 1;
        return true;
    };

    // The head as cpp-httplib is to read it (RequestHead::rewritten), and whether it differs.
    std::string out;
    out.reserve(head_bytes + 2);
    bool changed = false;
    const auto keep = [&](std::string_view l) {
        out.append(l.data(), l.size()).append("\r\n");
        // A line kept as received ends in CRLF right after it.
        const std::size_t end = static_cast<std::size_t>(l.data() - all.data()) + l.size();
        if (end >= all.size() || all[end] != '\r')
            changed = true;
    };

    std::string_view line;
    if (!next_line(line))
        return bad("no request line");
    // RFC 9112 §2.2: a server SHOULD ignore at least one empty line before the request line.
    if (line.empty()) {
        changed = true;
        if (!next_line(line))
            return bad("no request line");
    }
    keep(line);
    const std::size_t sp1 = line.find(' ');
    const std::size_t sp2 = sp1 == std::string_view::npos ? sp1 : line.find(' ', sp1 + 1);
    if (sp2 == std::string_view::npos || line.find(' ', sp2 + 1) != std::string_view::npos)
        return bad("the request line is not METHOD TARGET VERSION");
    const std::string_view method = line.substr(0, sp1);
    const std::string_view target = line.substr(sp1 + 1, sp2 - sp1 - 1);
    const std::string_view version = line.substr(sp2 + 1);
    if (!is_token(method))
        return bad("the method is not a token");
    if (target.size() > limits.max_target_bytes) {
        return refuse(414, ErrorCode::too_large,
                      "the URL is " + std::to_string(target.size()) + " bytes, over the limit of " +
                          std::to_string(limits.max_target_bytes));
    }
    if (target.empty() || target.front() != '/')
        return bad("the request target must start with /");
    if (version != "HTTP/1.1" && version != "HTTP/1.0")
        return refuse(505, ErrorCode::invalid_request, "only HTTP/1.0 and HTTP/1.1 are served");
    head.method = std::string(method);
    head.target = std::string(target);

    std::optional<std::string_view> content_length;
    bool transfer_encoding = false;
    bool content_encoding = false;
    while (next_line(line) && !line.empty()) {
        if (line.front() == ' ' || line.front() == '\t')
            return bad("obsolete line folding in the headers");
        // cpp-httplib refuses a longer line with a bare 400 of its own.
        if (line.size() + 2 > kMaxHeaderLineBytes) {
            return refuse(431, ErrorCode::too_large,
                          "a header line is over the limit of " +
                              std::to_string(kMaxHeaderLineBytes) + " bytes");
        }
        const std::size_t colon = line.find(':');
        if (colon == std::string_view::npos)
            return bad("a header line without a colon");
        const std::string_view name = line.substr(0, colon);
        // RFC 9112 §5.1: no whitespace between the field name and the colon.
        if (!is_token(name))
            return bad("a header name that is not a token");
        const std::string_view value = trim(line.substr(colon + 1));
        if (iequals(name, "Range")) {
            changed = true;
            continue;
        }
        if (iequals(name, "Content-Encoding")) {
            // What cpp-httplib decodes (App::read_body bounds the decoded bytes), or nothing; it
            // would take any other coding, or the second of two, for none and read the coded
            // bytes as the body.
            std::string coding(value);
            std::transform(coding.begin(), coding.end(), coding.begin(), [](char c) {
                return static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
            });
            if (coding != "gzip" && coding != "deflate" && coding != "br" && coding != "identity")
                return bad("Content-Encoding \"" + std::string(value.substr(0, 40)) +
                           "\" is not read; send gzip, deflate, br or identity");
            if (content_encoding)
                return bad("two Content-Encoding headers");
            content_encoding = true;
            if (coding != value)
                changed = true;
            out.append(name.data(), name.size()).append(": ").append(coding).append("\r\n");
            continue;
        }
        if (iequals(name, "Content-Length")) {
            if (value.empty() || !std::all_of(value.begin(), value.end(),
                                              [](char c) { return c >= '0' && c <= '9'; })) {
                return bad("Content-Length must be a decimal number of bytes, got \"" +
                           std::string(value.substr(0, 40)) + "\"");
            }
            if (content_length && *content_length != value)
                return bad("two different Content-Length headers");
            content_length = value;
        } else if (iequals(name, "Transfer-Encoding")) {
            if (!iequals(value, "chunked"))
                return bad("only Transfer-Encoding: chunked is understood");
            transfer_encoding = true;
        } else if (iequals(name, "Content-Type")) {
            const std::string_view media = trim(value.substr(0, value.find(';')));
            if (iequals(media, "application/x-www-form-urlencoded")) {
                changed = true;
                out.append(name.data(), name.size()).append(": text/plain\r\n");
                continue;
            }
        }
        keep(line);
    }
    // The blank line that ends the head: a bare LF one too.
    if (pos < 2 || all[pos - 2] != '\r')
        changed = true;
    out.append("\r\n");
    if (changed)
        head.rewritten = std::move(out);
    if (transfer_encoding && content_length)
        return bad("both Content-Length and Transfer-Encoding");
    head.chunked = transfer_encoding;
    if (content_length) {
        const std::string_view digits = *content_length;
        const std::size_t first = std::min(digits.find_first_not_of('0'), digits.size());
        const std::string_view significant = digits.substr(first);
        // 20 significant digits may already overflow 64 bits; any such length is over the limit.
        std::uint64_t n = 0;
        const bool huge = significant.size() > 19;
        if (!huge) {
            for (char c : significant)
                n = n * 10 + static_cast<std::uint64_t>(c - '0');
        }
        if (huge || n > limits.max_body_bytes) {
            return refuse(413, ErrorCode::too_large,
                          "request body of " + std::string(significant.substr(0, 24)) +
                              " bytes is over the limit of " +
                              std::to_string(limits.max_body_bytes));
        }
        head.content_length = n;
    }
    HeadCheck ok;
    ok.head = std::move(head);
    return ok;
}

}  // namespace raycastd::server
