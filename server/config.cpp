#include "server/config.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <map>
#include <vector>

#include <sys/resource.h>

namespace raycastd::server {

std::string usage() {
    return R"(raycastd: ray queries, previews, ray trees and worked solutions over HTTP

usage: raycastd [options]

  --host ADDR             address to listen on (default 127.0.0.1)
  --port N                port (default 8080; 0 picks a free port and prints it)
  --max-connections N     connections served at once, a thread each (default 512, at most
                          16384; each needs a file descriptor: ulimit -n); idle ones give
                          their thread up to new clients (--threads: the same)
  --scene-root DIR        mesh "uri"s resolve inside DIR only (default .)
  --data-dir DIR          persist registered scenes in DIR (default: memory only)
  --demo FILE             register the scene document FILE at start-up (repeatable)
  --max-body-mb N         largest request body (default 512)
  --max-rays N            most rays per intersect request (default 16777216)
  --max-points N          most points per points request (default 16777216)
  --max-pixels N          most width*height*spp per render (default 16777216)
  --max-texture-pixels N  largest texture image, read from its header before decoding; a
                          larger one, or one past 4*N for a scene's images together, is
                          dropped with a warning (default 16777216)
  --max-triangles N       most triangles per scene (default 50000000)
  --max-concurrent N      work requests in flight before 503 busy (default: 8 per hardware
                          thread, at least 64)
  --memory-budget-mb N    resident scene memory before least-recently-used eviction (default 4096)
  --body-budget-mb N      request bodies being received at once before 503 busy (default 2048)
  --answer-budget-mb N    answers being built or written at once before 503 busy (default 2048)
  --job-budget-mb N       finished async render images kept; past it the oldest finished
                          jobs are forgotten (default 512)
  --header-timeout-s N    a request's line and headers must arrive within N s (default 10)
  --idle-timeout-s N      a keep-alive connection may wait N s for its next request (default 5)
  --token T               writes (POST /v1/scenes, DELETE /v1/scenes/ID) need the header
                          "Authorization: Bearer T" (default: $RAYCASTD_TOKEN; none: open)
  --request-timeout-s N   stop a render, trace, ray batch or stateless scene build after N s
                          of work and answer 503 timeout (default 0: no limit)
  --log-level L           what goes to stderr, as JSON lines: error (internal errors),
                          warn (and requests answered 5xx), info (and every request: id,
                          method, route, status, duration_ms, rays; the default), debug (and
                          each request's path and sizes)
  --access-log            the same as --log-level info (kept for old command lines)
  --health-check          do not serve: ask the server at --host/--port (0.0.0.0: this
                          machine) for GET /v1/health and exit 0 if it answers 200 within
                          3 s, else 1 (a container's HEALTHCHECK)
  --help                  this text

Every option that takes a value, except --demo and --threads, may be given instead in the
environment as RAYCASTD_ and its name in capitals with _ for - (RAYCASTD_MAX_RAYS=1000,
RAYCASTD_DATA_DIR=/data, RAYCASTD_LOG_LEVEL=warn); a flag overrides its variable.
)";
}

namespace {

bool to_size(const char* s, std::size_t& out) {
    const char* end = s + std::strlen(s);
    auto r = std::from_chars(s, end, out);
    return r.ec == std::errc() && r.ptr == end;
}

std::string set_threads(Config& c, const std::string& a, std::size_t n) {
    // A thread each: past this, threads (and their stacks) rather than descriptors run out.
    // Descriptors are checked against RLIMIT_NOFILE at start-up (reserve_descriptors).
    if (n > kMaxConnections)
        return a + " must be at most " + std::to_string(kMaxConnections);
    c.threads = static_cast<int>(n);
    return {};
}

/// A number-valued option: stores n in the config, or returns why n is refused.
using NumberSetter = std::string (*)(Config&, const std::string& flag, std::size_t n);

/// Stores n · 2^Shift in a Limits field (Shift 20: a flag in MB, a field in bytes).
template <std::size_t Limits::*Field, unsigned Shift = 0>
std::string set_limit(Config& c, const std::string&, std::size_t n) {
    c.limits.*Field = n << Shift;
    return {};
}

/// Stores n in a Limits field when Lo ≤ n ≤ Hi.
template <std::size_t Limits::*Field, std::size_t Lo, std::size_t Hi>
std::string set_limit_within(Config& c, const std::string& flag, std::size_t n) {
    if (n < Lo || n > Hi) {
        return flag + (Lo == 0
                           ? " must be at most " + std::to_string(Hi)
                           : " must be from " + std::to_string(Lo) + " to " + std::to_string(Hi));
    }
    c.limits.*Field = n;
    return {};
}

/// The options that take a number, each with what it sets: one table, so that a flag is either
/// known here or "unknown option" whatever its value (--max-points was once listed by --help but
/// missing from a separate list of numeric flags, and refused).
const std::map<std::string, NumberSetter>& number_options() {
    static const std::map<std::string, NumberSetter> options = {
        {"--port",
         [](Config& c, const std::string&, std::size_t n) -> std::string {
             if (n > 65535)
                 return "--port must be at most 65535";
             c.port = static_cast<int>(n);
             return {};
         }},
        // --threads is --max-connections under its old name.
        {"--threads", &set_threads},
        {"--max-connections", &set_threads},
        {"--max-body-mb", &set_limit<&Limits::max_body_bytes, 20>},
        {"--max-rays", &set_limit<&Limits::max_rays>},
        {"--max-points", &set_limit<&Limits::max_points>},
        {"--max-pixels", &set_limit<&Limits::max_pixels>},
        {"--max-texture-pixels", &set_limit<&Limits::max_texture_pixels>},
        {"--max-triangles", &set_limit<&Limits::max_triangles>},
        {"--max-concurrent", &set_limit<&Limits::max_concurrent>},
        {"--memory-budget-mb", &set_limit<&Limits::memory_budget_bytes, 20>},
        {"--body-budget-mb", &set_limit<&Limits::body_budget_bytes, 20>},
        {"--answer-budget-mb", &set_limit<&Limits::answer_budget_bytes, 20>},
        {"--job-budget-mb", &set_limit<&Limits::job_budget_bytes, 20>},
        {"--header-timeout-s", &set_limit_within<&Limits::header_timeout_s, 1, 3600>},
        {"--idle-timeout-s", &set_limit_within<&Limits::idle_timeout_s, 1, 3600>},
        {"--request-timeout-s", &set_limit_within<&Limits::request_timeout_s, 0, 86400>},
    };
    return options;
}

}  // namespace

bool reserve_descriptors(std::size_t connections, std::string& error) {
    const rlim_t need = static_cast<rlim_t>(connections + kReservedDescriptors);
    rlimit lim{};
    if (::getrlimit(RLIMIT_NOFILE, &lim) != 0 || lim.rlim_cur >= need)
        return true;
    if (lim.rlim_max != RLIM_INFINITY && lim.rlim_max < need) {
        error = "--max-connections " + std::to_string(connections) + " needs " +
                std::to_string(need) + " file descriptors, and this process may open at most " +
                std::to_string(lim.rlim_max) +
                " (ulimit -Hn); lower --max-connections or raise "
                "the limit";
        return false;
    }
    // The soft limit may be raised up to the hard one without privileges (setrlimit(2)).
    lim.rlim_cur = need;
    if (::setrlimit(RLIMIT_NOFILE, &lim) != 0) {
        error = "cannot raise the file descriptor limit to " + std::to_string(need) +
                " for --max-connections " + std::to_string(connections) + ": " +
                std::strerror(errno);
        return false;
    }
    return true;
}

bool is_loopback_host(const std::string& host) {
    return host == "localhost" || host == "::1" || host == "[::1]" || host.rfind("127.", 0) == 0;
}

std::string env_name(const std::string& flag) {
    std::string out = "RAYCASTD_";
    for (char ch : flag.substr(2))
        out += ch == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    return out;
}

namespace {

/// The options that take a value and may come from the environment (--demo is repeatable and
/// --threads is --max-connections under its old name, so neither has a variable).
const std::vector<std::string>& env_flags() {
    static const std::vector<std::string> flags = {"--host",
                                                   "--port",
                                                   "--max-connections",
                                                   "--scene-root",
                                                   "--data-dir",
                                                   "--max-body-mb",
                                                   "--max-rays",
                                                   "--max-points",
                                                   "--max-pixels",
                                                   "--max-texture-pixels",
                                                   "--max-triangles",
                                                   "--max-concurrent",
                                                   "--memory-budget-mb",
                                                   "--body-budget-mb",
                                                   "--answer-budget-mb",
                                                   "--job-budget-mb",
                                                   "--header-timeout-s",
                                                   "--idle-timeout-s",
                                                   "--request-timeout-s",
                                                   "--token",
                                                   "--log-level"};
    return flags;
}

/// Applies one option and its value to `c`; the error's text, or empty.
std::string apply(Config& c, const std::string& a, const std::string& v) {
    std::size_t n = 0;
    const bool numeric = to_size(v.c_str(), n);
    if (a == "--host") {
        c.host = v;
    } else if (a == "--scene-root") {
        c.scene_root = v;
    } else if (a == "--data-dir") {
        c.data_dir = v;
    } else if (a == "--demo") {
        c.demo.push_back(v);
    } else if (a == "--token") {
        if (v.empty())
            return "--token must not be empty";
        c.token = v;
    } else if (a == "--log-level") {
        const auto level = parse_log_level(v);
        if (!level)
            return "--log-level must be error, warn, info or debug, got \"" + v + "\"";
        c.log_level = *level;
    } else if (const auto o = number_options().find(a); o == number_options().end()) {
        return "unknown option " + a;
    } else if (!numeric) {
        return a + " needs a non-negative whole number, got \"" + v + "\"";
    } else {
        return o->second(c, a, n);
    }
    return {};
}

}  // namespace

std::optional<Config> parse_args(int argc, char** argv, std::string& message, bool& error) {
    Config c;
    error = false;
    auto fail = [&](const std::string& m) {
        message = "raycastd: " + m + "\n(see raycastd --help)\n";
        error = true;
        return std::nullopt;
    };
    // The environment first, so that a flag given too overrides it (a container's image sets
    // variables, its command line the exceptions).
    for (const std::string& flag : env_flags()) {
        const std::string var = env_name(flag);
        const char* env = std::getenv(var.c_str());
        if (!env || (flag == "--token" && *env == '\0'))
            continue;
        const std::string e = apply(c, flag, env);
        if (!e.empty())
            return fail(var + "=" + env + ": " + e);
    }
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--help" || a == "-h") {
            message = usage();
            return std::nullopt;
        }
        if (a == "--health-check") {
            c.health_check = true;
            continue;
        }
        if (a == "--access-log") {
            // Kept from before --log-level: request lines are the info level.
            c.log_level = std::max(c.log_level, LogLevel::info);
            continue;
        }
        if (i + 1 >= argc)
            return fail("missing value for " + a);
        const std::string e = apply(c, a, argv[++i]);
        if (!e.empty())
            return fail(e);
    }
    return c;
}

}  // namespace raycastd::server
