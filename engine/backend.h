#pragma once
// What the engine is built on, for /v1/info: the server reports it without linking the backend.

#include <string>

namespace raycastd::engine {

/// The version of the ray-tracing backend the engine was built against (Embree's
/// RTC_VERSION_STRING, e.g. "3.13.5").
std::string backend_version();

}  // namespace raycastd::engine
