#pragma once
// Status and Result<T>: how the engine reports data errors without throwing across its API.
// The server maps each Code to one HTTP status and one stable `code` string (server/api_error).

#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace raycastd::engine {

/// What went wrong, in the engine's terms; the server owns the mapping to HTTP.
enum class Code {
    ok,
    invalid_scene,       ///< a scene description breaks a rule (negative radius, unknown material)
    invalid_ray,         ///< a ray is unusable (zero or non-finite direction, tmin > tmax)
    invalid_request,     ///< a request option is unusable (unknown mode, bad field name)
    model_load_failed,   ///< a model file parsed but cannot be used (index out of range, ...)
    unsupported_format,  ///< a model format we do not read
    too_large,           ///< over a configured limit, or out of memory in a backend
    not_found,           ///< a referenced thing does not exist
    cancelled,           ///< the work was stopped by its CancelToken (engine/cancel.h)
    internal,            ///< a bug or a backend failure we cannot attribute to the input
};

/// A Code with a human message and, where it applies, a JSON pointer to the offending input.
struct Status {
    Code code = Code::ok;
    std::string message;
    std::string path;  ///< JSON pointer ("/objects/2/radius"), empty when not applicable

    bool ok() const { return code == Code::ok; }
    static Status error(Code c, std::string msg, std::string p = {}) {
        return Status{c, std::move(msg), std::move(p)};
    }
};

/// A value or the Status that explains why there is none.
template <class T>
class Result {
  public:
    Result(T value) : v_(std::move(value)) {}         // NOLINT: implicit by design
    Result(Status status) : v_(std::move(status)) {}  // NOLINT: implicit by design

    bool ok() const { return std::holds_alternative<T>(v_); }
    explicit operator bool() const { return ok(); }
    const T& value() const& { return std::get<T>(v_); }
    T& value() & { return std::get<T>(v_); }
    T&& value() && { return std::get<T>(std::move(v_)); }
    const T& operator*() const& { return value(); }
    T& operator*() & { return value(); }
    const T* operator->() const { return &value(); }
    T* operator->() { return &value(); }
    /// The error; only meaningful when !ok().
    const Status& status() const { return std::get<Status>(v_); }

  private:
    std::variant<T, Status> v_;
};

}  // namespace raycastd::engine
