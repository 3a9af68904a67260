// GET /, GET /web/<path>: the preview page's static files (server/static_files.h).

#include "server/routes_web.h"

#include <cstdlib>
#include <memory>

#include "server/app.h"
#include "server/static_files.h"

namespace raycastd::server {

namespace {

// The page talks only to this server and loads nothing from elsewhere (no CDN); blob: and data:
// images are the rendered previews.
constexpr const char* kContentSecurityPolicy =
    "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; script-src 'self'; "
    "style-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'self'";

void serve(const StaticFiles& files, const std::string& relative, const httplib::Request& req,
           httplib::Response& res) {
    StaticResult r = files.read(relative);
    if (!r.file) {
        throw ApiError(
            r.error == StaticError::refused ? ErrorCode::invalid_request : ErrorCode::not_found,
            r.message);
    }
    // Development-friendly caching: always revalidate (no-cache), answered by a 304 while the
    // file is unchanged, so an edited page shows on the next reload.
    res.set_header("Cache-Control", "no-cache");
    res.set_header("ETag", r.file->etag);
    res.set_header("X-Content-Type-Options", "nosniff");
    if (r.file->mime_type.rfind("text/html", 0) == 0) {
        res.set_header("Content-Security-Policy", kContentSecurityPolicy);
        res.set_header("Referrer-Policy", "no-referrer");
    }
    if (req.get_header_value("If-None-Match") == r.file->etag) {
        res.status = 304;
        return;
    }
    res.status = 200;
    res.set_content(std::move(r.file->body), r.file->mime_type);
}

}  // namespace

std::string web_root() {
    const char* env = std::getenv("RAYCASTD_WEB_ROOT");
    return env && *env ? std::string(env) : std::string(RAYCASTD_WEB_ROOT_DEFAULT);
}

void install_web_routes(App& app) {
    auto files = std::make_shared<const StaticFiles>(web_root());
    app.on_get("/", [&app, files](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] { serve(*files, "index.html", req, res); });
    });
    app.on_get("/web/(.*)", [&app, files](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] { serve(*files, req.matches[1].str(), req, res); });
    });
}

}  // namespace raycastd::server
