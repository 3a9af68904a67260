#pragma once
// GET / and GET /web/...: the preview page (docs/api.md, "GET /"), served from clients/web/.

#include <string>

namespace raycastd::server {

class App;

/// The directory the page is served from: $RAYCASTD_WEB_ROOT when set, else the source tree's
/// clients/web (the RAYCASTD_WEB_ROOT_DEFAULT compile definition).
std::string web_root();

/// Installs GET / (index.html) and GET /web/<path> (the page's other files). Files are read at
/// request time, so an edit to the page shows on reload without a rebuild.
void install_web_routes(App& app);

}  // namespace raycastd::server
