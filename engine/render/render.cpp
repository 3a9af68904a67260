#include "engine/render/render.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <vector>

#include <tbb/parallel_for.h>

#include "engine/render/camera_rays.h"
#include "engine/render/image.h"
#include "engine/thread_scratch.h"

namespace raycastd::engine {

namespace {

/// SplitMix64 (Steele, Lea & Flood 2014): a stateless hash giving each sample its own jitter,
/// so that a render is the same whatever thread draws which tile.
double hash01(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    x ^= x >> 31;
    return static_cast<double>(x >> 11) * 0x1.0p-53;
}

/// A well-spread colour per object: hues a golden-ratio step apart (HSV with s = 0.65, v = 0.95).
Vec3d object_color(std::uint32_t id) {
    const double h = std::fmod(0.1 + 0.6180339887498949 * id, 1.0) * 6.0;
    const double s = 0.65, v = 0.95;
    const double f = h - std::floor(h);
    const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    switch (static_cast<int>(h)) {
        case 0:
            return {v, t, p};
        case 1:
            return {q, v, p};
        case 2:
            return {p, v, t};
        case 3:
            return {p, q, v};
        case 4:
            return {t, p, v};
        default:
            return {v, p, q};
    }
}

/// Everything a tile needs, built once per render.
struct Frame {
    const Whitted& whitted;
    const RenderOptions& opt;
    CameraRays camera;
    int strata_x, strata_y;
    double near, far;  ///< depth normalisation: the bounding sphere seen from the camera

    /// The colour of one camera sample whose closest hit (if any) is known.
    Vec3d shade(const Ray& ray, const Hit& hit, RayCounts& counts) const {
        if (!hit.valid())
            return is_data_mode(opt.shading) ? Vec3d{} : opt.whitted.background;
        switch (opt.shading) {
            case ShadingMode::phong:
                return whitted.shade_hit(ray, hit, counts);
            case ShadingMode::normal:
                return (whitted.shading_normal(hit) + Vec3d{1, 1, 1}) * 0.5;
            case ShadingMode::depth: {
                const double d = 1.0 - (hit.t - near) / (far - near);
                const double c = std::clamp(d, 0.0, 1.0);
                return {c, c, c};
            }
            case ShadingMode::object_id:
                return object_color(hit.object);
            case ShadingMode::barycentric:
                return {1.0 - hit.u - hit.v, hit.u, hit.v};
        }
        return {};
    }

    /// The camera ray of sample s of pixel (x, y), written into `r`: the pixel centre for one
    /// sample, else jittered inside cell (s mod nx, s div nx) of an nx × ny grid over the pixel
    /// (stratified).
    void sample_ray(Ray& r, int x, int y, int s) const {
        double px, py;
        sample_point(x, y, s, px, py);
        camera.ray(r, px, py);
    }

    /// sample_ray for pixels x … x + 3 of row y, into out[0..4), the same bits
    /// (CameraRays::rays4). The jitter's two divisions stay one point at a time: done four
    /// lanes at a time as well, making camera rays took 10% longer, not less (rdtsc, three
    /// alternating pairs, 2026-12-07).
    void sample_rays4(Ray* out, int x, int y, int s) const {
        double px[4], py[4];
        for (int j = 0; j < 4; ++j)
            sample_point(x + j, y, s, px[j], py[j]);
        camera.rays4(out, px, py);
    }

    /// The image point sample_ray traces through.
    void sample_point(int x, int y, int s, double& px, double& py) const {
        if (opt.spp == 1) {
            px = x + 0.5;
            py = y + 0.5;
            return;
        }
        const std::uint64_t key =
            ((static_cast<std::uint64_t>(y) * static_cast<std::uint64_t>(opt.width) +
              static_cast<std::uint64_t>(x)) *
                 static_cast<std::uint64_t>(opt.spp) +
             static_cast<std::uint64_t>(s)) *
            2;
        const int cx = s % strata_x, cy = s / strata_x;
        px = x + (cx + hash01(key)) / strata_x;
        py = y + (cy + hash01(key + 1)) / strata_y;
    }
};

/// trace_samples' buffers, leased for each call (engine/thread_scratch.h): they keep their size
/// from one tile to the next, and a tile writes its own elements over what is left there.
struct SampleScratch {
    std::vector<Ray> rays;
    // Each sample's pixel as its index into sums: one 4-byte store. An {x, y} pair was written
    // in two 4-byte pieces and read back in one 8-byte one when pushed, a store-forwarding
    // stall per camera ray (perf annotate).
    std::vector<std::uint32_t> where;
    std::vector<Hit> hits;
    std::vector<Vec3d> colors;

    std::size_t bytes() const {
        return capacity_bytes(rays) + capacity_bytes(where) + capacity_bytes(hits) +
               capacity_bytes(colors);
    }
};

/// Traces samples [s0, s1) of the pixels of [x0, x1) × [y0, y1) for which want(x, y) holds and
/// adds each sample's colour to sums[(y − y0)·(x1 − x0) + (x − x0)]. The camera rays are traced
/// as one batch ordered in 4 × 4 pixel blocks, sample by sample, so that each run of 16 rays is
/// coherent (the engine traces such runs as Embree packets where that is faster); then each hit
/// is shaded.
template <class Want>
void trace_samples(const Frame& f, int x0, int y0, int x1, int y1, int s0, int s1, const Want& want,
                   std::vector<Vec3d>& sums, RayCounts& counts) {
    // Leased, not one per thread: while this thread waits inside the batch's own parallel loop,
    // TBB may hand it another tile.
    ThreadScratch<SampleScratch> scratch;
    const int w = x1 - x0;
    const std::size_t n = static_cast<std::size_t>(w * (y1 - y0) * (s1 - s0));
    // Sized for every sample, each ray written into its slot (CameraRays::ray); only the samples
    // wanted are traced.
    Ray* const rays = slots(scratch->rays, n);
    std::uint32_t* const where = slots(scratch->where, n);
    std::size_t wanted = 0;
    const auto pixel = [&](int x, int y) {
        return static_cast<std::uint32_t>((y - y0) * w + (x - x0));
    };
    for (int by = y0; by < y1; by += 4) {
        for (int bx = x0; bx < x1; bx += 4) {
            for (int s = s0; s < s1; ++s) {
                for (int y = by; y < std::min(by + 4, y1); ++y) {
                    // A whole row of the block wanted: its four rays at once.
                    if (bx + 4 <= x1 && want(bx, y) && want(bx + 1, y) && want(bx + 2, y) &&
                        want(bx + 3, y)) {
                        f.sample_rays4(&rays[wanted], bx, y, s);
                        for (int x = bx; x < bx + 4; ++x)
                            where[wanted++] = pixel(x, y);
                        continue;
                    }
                    for (int x = bx; x < std::min(bx + 4, x1); ++x) {
                        if (!want(x, y))
                            continue;
                        f.sample_ray(rays[wanted], x, y, s);
                        where[wanted++] = pixel(x, y);
                    }
                }
            }
        }
    }
    if (wanted == 0)
        return;
    Hit* const hits = slots(scratch->hits, wanted);
    f.whitted.closest_batch(rays, wanted, hits);
    counts.primary += wanted;
    Vec3d* const colors = slots(scratch->colors, wanted);
    if (f.opt.shading == ShadingMode::phong) {
        // Generation by generation, in packets.
        f.whitted.shade_hits(rays, hits, wanted, colors, counts);
    } else {
        for (std::size_t i = 0; i < wanted; ++i)
            colors[i] = f.shade(rays[i], hits[i], counts);
    }
    for (std::size_t i = 0; i < wanted; ++i)
        sums[where[i]] += colors[i];
}

/// Renders the pixels [x0, x1) × [y0, y1): every sample of every pixel.
void tile_pixels(const Frame& f, int x0, int y0, int x1, int y1, Image& image, RayCounts& counts) {
    const int w = x1 - x0;
    std::vector<Vec3d> sums(static_cast<std::size_t>(w * (y1 - y0)));
    trace_samples(
        f, x0, y0, x1, y1, 0, f.opt.spp, [](int, int) { return true; }, sums, counts);
    for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
            image.set(x, y,
                      sums[static_cast<std::size_t>((y - y0) * w + (x - x0))] /
                          static_cast<double>(f.opt.spp));
        }
    }
}

/// What adaptive sampling's first pass leaves for the second, over the whole image: each
/// pixel's first sample, the 8-bit value it shows as (as encode_image writes it: sRGB for phong,
/// linear for the data modes), and, once the first pass is over, whether it gets more samples.
/// Left unwritten when made (DefaultInitAllocator), as the image is: the first pass writes every
/// pixel's colour and shown value and mark_more every flag, from every thread (a cancelled
/// first pass skips both the marking and the second pass). Zero-filled here, its 22 MB at
/// 1024×768 had been first touched by one thread before any tile: 58 ms of page faults in two
/// of bench_render's three tutorial_like runs (glibc maps a fresh block until its mmap
/// threshold has grown). Measured paired at spp 4, fast: that adaptive render's median went
/// from 417–461 ms to 386–390 ms. A mapping of its own advised for huge pages was tried too:
/// 362–366 ms there, but the Duck rendered next went from 200 to 220 ms, since every render then
/// faults its buffer afresh where glibc's heap had kept the last one.
struct FirstSamples {
    int width = 0, height = 0;
    std::vector<double, DefaultInitAllocator<double>> rgb;  ///< 3 per pixel
    std::vector<std::array<unsigned char, 3>, DefaultInitAllocator<std::array<unsigned char, 3>>>
        shown;
    std::vector<char, DefaultInitAllocator<char>> more;

    FirstSamples(int w, int h)
        : width(w), height(h), rgb(3 * pixels()), shown(pixels()), more(pixels()) {}
    Vec3d color(std::size_t i) const { return {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]}; }
    void set_color(std::size_t i, const Vec3d& c) {
        rgb[3 * i] = c.x;
        rgb[3 * i + 1] = c.y;
        rgb[3 * i + 2] = c.z;
    }
    std::size_t pixels() const {
        return static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    }
    std::size_t index(int x, int y) const {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
               static_cast<std::size_t>(x);
    }
    /// Whether pixel (x, y)'s first sample shows differently from one of its four neighbours'.
    bool differs(int x, int y) const {
        const auto& c = shown[index(x, y)];
        return (x > 0 && shown[index(x - 1, y)] != c) ||
               (x + 1 < width && shown[index(x + 1, y)] != c) ||
               (y > 0 && shown[index(x, y - 1)] != c) ||
               (y + 1 < height && shown[index(x, y + 1)] != c);
    }
};

/// Adaptive sampling, first pass: sample 0 of every pixel of the tile.
void tile_first_samples(const Frame& f, int x0, int y0, int x1, int y1, FirstSamples& first,
                        RayCounts& counts) {
    const int w = x1 - x0;
    std::vector<Vec3d> sums(static_cast<std::size_t>(w * (y1 - y0)));
    trace_samples(
        f, x0, y0, x1, y1, 0, 1, [](int, int) { return true; }, sums, counts);
    const bool linear = is_data_mode(f.opt.shading);
    for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
            const Vec3d& c = sums[static_cast<std::size_t>((y - y0) * w + (x - x0))];
            const std::size_t i = first.index(x, y);
            first.set_color(i, c);
            for (std::size_t k = 0; k < 3; ++k)
                first.shown[i][k] = encode_8bit(static_cast<float>(c[k]), linear);
        }
    }
}

/// Marks the pixels that get more samples (FirstSamples::more) once the first pass is over;
/// returns how many.
std::size_t mark_more(FirstSamples& first) {
    std::atomic<std::size_t> total{0};
    tbb::parallel_for(0, first.height, [&](int y) {
        std::size_t row = 0;
        for (int x = 0; x < first.width; ++x) {
            const bool more = first.differs(x, y);
            first.more[first.index(x, y)] = more;
            row += more;
        }
        total.fetch_add(row, std::memory_order_relaxed);
    });
    return total.load();
}

/// Adaptive sampling, second pass: samples 1..spp of each pixel marked for more (mark_more),
/// averaged with its first (summed in the order tile_pixels sums them, so such a pixel is
/// exactly the uniform render's); the other pixels keep their first sample.
void tile_more_samples(const Frame& f, int x0, int y0, int x1, int y1, const FirstSamples& first,
                       Image& image, RayCounts& counts) {
    const int w = x1 - x0;
    const auto local = [&](int x, int y) {
        return static_cast<std::size_t>((y - y0) * w + (x - x0));
    };
    std::vector<Vec3d> sums(static_cast<std::size_t>(w * (y1 - y0)));
    for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x)
            sums[local(x, y)] = first.color(first.index(x, y));
    }
    const auto want = [&](int x, int y) { return first.more[first.index(x, y)] != 0; };
    trace_samples(f, x0, y0, x1, y1, 1, f.opt.spp, want, sums, counts);
    for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x)
            image.set(x, y,
                      want(x, y) ? sums[local(x, y)] / static_cast<double>(f.opt.spp)
                                 : sums[local(x, y)]);
    }
}

}  // namespace

std::optional<ShadingMode> shading_mode_from_name(std::string_view name) {
    if (name == "phong")
        return ShadingMode::phong;
    if (name == "normal")
        return ShadingMode::normal;
    if (name == "depth")
        return ShadingMode::depth;
    if (name == "object_id")
        return ShadingMode::object_id;
    if (name == "barycentric")
        return ShadingMode::barycentric;
    return std::nullopt;
}

const char* to_string(ShadingMode mode) {
    switch (mode) {
        case ShadingMode::phong:
            return "phong";
        case ShadingMode::normal:
            return "normal";
        case ShadingMode::depth:
            return "depth";
        case ShadingMode::object_id:
            return "object_id";
        case ShadingMode::barycentric:
            return "barycentric";
    }
    return "phong";
}

std::optional<Lighting> lighting_from_name(std::string_view name) {
    if (name == "scene")
        return Lighting::scene;
    if (name == "headlight")
        return Lighting::headlight;
    if (name == "auto")
        return Lighting::automatic;
    return std::nullopt;
}

const char* to_string(Lighting lighting) {
    switch (lighting) {
        case Lighting::scene:
            return "scene";
        case Lighting::headlight:
            return "headlight";
        case Lighting::automatic:
            return "auto";
    }
    return "auto";
}

Lighting resolve_lighting(const Scene& scene, Lighting asked) {
    if (asked != Lighting::automatic)
        return asked;
    // An ambient light alone does not count: it would still give a flat silhouette.
    const bool lit = std::any_of(scene.lights.begin(), scene.lights.end(),
                                 [](const Light& l) { return l.type != LightType::ambient; });
    return lit ? Lighting::scene : Lighting::headlight;
}

std::size_t tile_count(const RenderOptions& o) {
    const auto tiles = [&](int n) {
        return static_cast<std::size_t>((n + o.tile_size - 1) / o.tile_size);
    };
    return tiles(o.width) * tiles(o.height);
}

std::size_t thread_scratch_bytes() {
    return ThreadScratch<SampleScratch>::kept_bytes() + Whitted::thread_scratch_bytes();
}

Result<RenderResult> render(const QueryEngine& engine, const RenderOptions& opt,
                            RenderProgress* progress) {
    const auto start = std::chrono::steady_clock::now();
    // The calling thread runs tiles too: on the way out (cancelled or not) it frees the batch
    // buffers it kept (engine/thread_scratch.h), so that a thread that asked for one render, an
    // HTTP connection's, does not hold them until it exits.
    struct ReleaseScratch {
        ~ReleaseScratch() {
            ThreadScratch<SampleScratch>::release_all();
            Whitted::release_thread_scratch();
        }
    } release_scratch;
    const Scene& scene = engine.scene();
    const Camera cam = resolve_camera(scene, opt.camera, opt.width, opt.height);
    const Lighting lighting = resolve_lighting(scene, opt.lighting);
    WhittedOptions wo = opt.whitted;
    wo.many_rays = true;
    wo.headlight = std::nullopt;
    if (lighting == Lighting::headlight) {
        // The camera's view direction; a degenerate camera (look_at = position) has none.
        const Vec3d f = normalize(cam.look_at - cam.position);
        if (is_finite(f) && length(f) > 0.0)
            wo.headlight = f;
    }
    const Whitted whitted(engine, wo);
    const Bounds3 b = scene.bounds();
    const double radius = b.empty() ? 1.0 : 0.5 * scaled_length(b.diagonal());
    const double dist = b.empty() ? 0.0 : length(b.center() - cam.position);
    const int nx = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(opt.spp))));
    const Frame frame{whitted,
                      opt,
                      CameraRays(cam, opt.width, opt.height),
                      nx,
                      (opt.spp + nx - 1) / nx,
                      std::max(0.0, dist - radius),
                      std::max(dist + radius, std::max(0.0, dist - radius) + 1e-300)};

    RenderResult out;
    out.precision = whitted.effective_precision();
    out.lighting = lighting;
    // Every pixel is written by its tile: the image is not zero-filled first.
    out.image = Image(opt.width, opt.height, Image::Fill::unset);
    const int tiles_x = (opt.width + opt.tile_size - 1) / opt.tile_size;
    const std::size_t total = tile_count(opt);
    if (progress)
        progress->tiles_total = total;
    std::mutex counts_mutex;
    // Calls tile_work(x0, y0, x1, y1, counts) for every tile, over the threads.
    const auto each_tile = [&](const auto& tile_work) {
        tbb::parallel_for(std::size_t{0}, total, [&](std::size_t tile) {
            if (opt.cancel.cancelled())
                return;
            const int x0 =
                static_cast<int>(tile % static_cast<std::size_t>(tiles_x)) * opt.tile_size;
            const int y0 =
                static_cast<int>(tile / static_cast<std::size_t>(tiles_x)) * opt.tile_size;
            const int x1 = std::min(x0 + opt.tile_size, opt.width);
            const int y1 = std::min(y0 + opt.tile_size, opt.height);
            RayCounts counts;
            tile_work(x0, y0, x1, y1, counts);
            {
                std::lock_guard<std::mutex> lock(counts_mutex);
                out.counts += counts;
            }
            if (progress) {
                progress->tiles_done.fetch_add(1, std::memory_order_relaxed);
                progress->samples_done.fetch_add(counts.primary, std::memory_order_relaxed);
            }
        });
    };
    const std::size_t pixels =
        static_cast<std::size_t>(opt.width) * static_cast<std::size_t>(opt.height);
    if (progress)
        progress->samples_total = pixels * static_cast<std::size_t>(opt.spp);
    if (opt.adaptive && opt.spp > 1) {
        // Two passes over the tiles: a pixel's neighbours in the next tile must have their
        // first sample before it is decided whether the pixel needs more.
        if (progress)
            progress->tiles_total = 2 * total;
        FirstSamples first(opt.width, opt.height);
        each_tile([&](int x0, int y0, int x1, int y1, RayCounts& counts) {
            tile_first_samples(frame, x0, y0, x1, y1, first, counts);
        });
        if (!opt.cancel.cancelled()) {
            const std::size_t more = mark_more(first);
            // The samples the second pass will trace are known now (until now the total
            // assumed every pixel needed them: a job's estimate erred long, not short).
            if (progress)
                progress->samples_total = pixels + more * static_cast<std::size_t>(opt.spp - 1);
        }
        each_tile([&](int x0, int y0, int x1, int y1, RayCounts& counts) {
            tile_more_samples(frame, x0, y0, x1, y1, first, out.image, counts);
        });
    } else {
        each_tile([&](int x0, int y0, int x1, int y1, RayCounts& counts) {
            tile_pixels(frame, x0, y0, x1, y1, out.image, counts);
        });
    }
    if (opt.cancel.fired())
        return opt.cancel.status();  // `out` and its image go here
    out.render_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return out;
}

}  // namespace raycastd::engine
