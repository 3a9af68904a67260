#pragma once
// The OpenAPI 3 description of the API, served at /v1/openapi.json. Its source is
// docs/openapi.json, compiled in at build time so the served file and the documented one are
// the same bytes.

#include <string>

namespace raycastd::server {

const std::string& openapi_document();

}  // namespace raycastd::server
