#pragma once
// The worked solution of POST /v1/explain as JSON (the shape in docs/api.md) and as Markdown with
// LaTeX.

#include <string>

#include "engine/explain/explain.h"

namespace raycastd::server {

std::string write_explain_json(const engine::Explanation& ex, const engine::Ray& ray);
std::string write_explain_markdown(const engine::Explanation& ex, const engine::Ray& ray);

}  // namespace raycastd::server
