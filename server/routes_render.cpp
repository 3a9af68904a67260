// POST /v1/scenes/{id}/render and /v1/jobs/...: arriving with issue 5 (no routes yet, so they
// answer 404 not_found).

#include "server/app.h"

namespace raycastd::server {

void install_render_routes(App&) {}

}  // namespace raycastd::server
