#pragma once
// Renders an image of a prepared scene: camera rays through stratified samples in each pixel,
// shaded by the Whitted tracer (shading "phong") or showing data (normal, depth, object_id,
// barycentric), in tiles spread over TBB's workers. Progress is the count of tiles done; a
// render is cancelled between tiles by its options' CancelToken (engine/cancel.h).

#include <atomic>
#include <cstddef>
#include <optional>
#include <string_view>

#include "engine/cancel.h"
#include "engine/query/intersect.h"
#include "engine/render/image.h"
#include "engine/scene/camera.h"
#include "engine/shade/whitted.h"

namespace raycastd::engine {

enum class ShadingMode { phong, normal, depth, object_id, barycentric };

/// "phong", "normal", "depth", "object_id", "barycentric" → the mode; nullopt otherwise.
std::optional<ShadingMode> shading_mode_from_name(std::string_view name);
const char* to_string(ShadingMode mode);
/// True for the modes whose pixels are data rather than light (stored without the sRGB curve).
inline bool is_data_mode(ShadingMode mode) {
    return mode != ShadingMode::phong;
}

/// Which lights a phong render uses (docs/api.md, render `lighting`): the scene's own; a
/// headlight (ambient 0.1 and a directional light of 0.9 along the camera's view direction) in
/// their place; or `automatic` ("auto"): the scene's when it has a point or directional light,
/// else the headlight, so that a bare model file renders shaded rather than flat.
enum class Lighting { scene, headlight, automatic };

/// "scene", "headlight", "auto" → the lighting; nullopt otherwise.
std::optional<Lighting> lighting_from_name(std::string_view name);
const char* to_string(Lighting lighting);
/// `asked` with `automatic` decided for `scene` (scene or headlight; never automatic).
Lighting resolve_lighting(const Scene& scene, Lighting asked);

struct RenderOptions {
    int width = 640;
    int height = 480;
    int spp = 1;  ///< samples per pixel, stratified over the pixel (1: its centre)
    /// Adaptive sampling ("sampling": "adaptive"): every pixel's first sample is traced, and
    /// only a pixel whose first sample shows a different 8-bit value from one of its four
    /// neighbours' gets the other spp − 1 (render.cpp). False: every pixel gets spp samples.
    bool adaptive = false;
    ShadingMode shading = ShadingMode::phong;
    Lighting lighting = Lighting::automatic;
    /// max_depth, precision, background (its headlight is set by render() from `lighting`)
    WhittedOptions whitted;
    std::optional<Camera> camera;  ///< the request's camera (else the scene's, else framing)
    int tile_size = 16;            ///< pixels per tile side
    /// Asked once per tile (never per ray): once it fires, tiles not yet begun are skipped and
    /// the render answers Code::cancelled.
    CancelToken cancel{};
};

/// How far a render has come, shared with whoever watches it (RenderOptions::cancel stops it).
struct RenderProgress {
    std::atomic<std::size_t> tiles_done{0};
    std::atomic<std::size_t> tiles_total{0};  ///< an adaptive render counts each tile twice
    /// Camera samples traced, and to trace: the measure of progress (an adaptive render's two
    /// passes differ in cost; its total is every pixel's spp until the first pass has told
    /// which pixels get more).
    std::atomic<std::size_t> samples_done{0};
    std::atomic<std::size_t> samples_total{0};
};

struct RenderResult {
    Image image;  ///< linear RGB (phong), or the data of the mode in [0, 1]
    RayCounts counts;
    double render_ms = 0.0;
    Precision precision = Precision::exact;  ///< the path that answered
    Lighting lighting = Lighting::scene;     ///< the lighting used (automatic decided)
};

/// The number of tiles a render of `options` is cut into.
std::size_t tile_count(const RenderOptions& options);

/// Renders `engine`'s scene. Options must be valid (width, height, spp ≥ 1; max_depth ≥ 1).
/// Depth is 1 at the nearest point of the scene's bounding sphere and 0 at its farthest (and on
/// a miss); object_id gives each object a distinct colour; barycentric shows (1−u−v, u, v).
/// Code::cancelled, with the image freed, once options.cancel has fired.
Result<RenderResult> render(const QueryEngine& engine, const RenderOptions& options,
                            RenderProgress* progress = nullptr);

/// The bytes of batch buffers (engine/thread_scratch.h) that the calling thread keeps for its
/// next tiles: 0 once a render() called on this thread has returned, which frees them, so that
/// a thread that asked for one render (an HTTP connection's) does not hold them until it exits.
std::size_t thread_scratch_bytes();

}  // namespace raycastd::engine
