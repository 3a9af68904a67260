#pragma once
// Pinhole camera rays. The camera looks from `position` towards `look_at`; `up` fixes the roll;
// `fov_y_deg` is the vertical field of view. The image plane sits at distance 1:
//
//   d(x, y) = f + (2x/W − 1)·tan(fov/2)·(W/H)·r + (1 − 2y/H)·tan(fov/2)·u
//
// with f the unit forward vector, r = normalize(f × up) the right vector and u = r × f the true
// up vector; (x, y) are pixel coordinates with (0, 0) at the top-left corner of the image.
// Which camera a render uses: the request's, else the scene's (its document's, else its glTF
// file's), else one whose bounding sphere fills the image, seen from +z where the scene has a
// model file and from −z where it has only spheres and triangles (engine/scene/scene.h
// default_camera, Scene::default_view).

#include <optional>

#include "engine/math/ray.h"
#include "engine/scene/scene.h"

namespace raycastd::engine {

/// The camera a width × height render of `scene` uses given the one the request asked for (if
/// any): the request's, else the scene's, else default_camera(bounds, width / height,
/// scene.default_view()).
Camera resolve_camera(const Scene& scene, const std::optional<Camera>& requested, int width,
                      int height);

/// Precomputed frame of a camera for a W × H image.
class CameraRays {
  public:
    CameraRays(const Camera& camera, int width, int height);
    /// The ray through image point (x, y) in pixels (x right, y down); unit direction.
    Ray ray(double x, double y) const {
        Ray r;
        ray(r, x, y);
        return r;
    }
    /// The same ray written into `r`, field by field: a batch writes its camera rays into their
    /// slots this way. Inline: returned from another file, the Ray was written in 8-byte pieces
    /// and read back in 16-byte ones by the caller copying it into its batch, a store-forwarding
    /// stall per camera ray (the hottest instructions of render's trace_samples, perf annotate);
    /// inline but returned, LTO's build of the batch loop did the same through a stack copy
    /// (27% of trace_samples' samples on one 16-byte load, perf annotate, 2026-12-07).
    void ray(Ray& r, double x, double y) const {
        r.origin = origin_;
        r.direction = normalize(forward_ + right_ * (2.0 * x / width_ - 1.0) +
                                up_ * (1.0 - 2.0 * y / height_));
        r.tmin = 0.0;
        r.tmax = kInfinity;
    }
    /// ray(out[j], x[j], y[j]) for j < 4, the same bits, four rays to an instruction in AVX's
    /// registers where the processor has AVX (one by one elsewhere). A camera ray takes five
    /// divisions and a square root here, which one ray at a time queue on the divider: making
    /// camera rays was 8.6% of the timestamp ticks counted around a Duck render's phases at
    /// fast, and 7.2% four at a time (rdtsc, three alternating pairs, 2026-12-07).
    void rays4(Ray* out, const double* x, const double* y) const;

  private:
    Vec3d origin_, forward_, right_, up_;
    double width_, height_;
};

}  // namespace raycastd::engine
