#pragma once
// Inside or outside, object by object, for a batch of points whose nearest surface point is
// known (point_queries.h computes it first).
//
//   on a surface   within the nearest hit's error bound: inside, winding 1, nothing else asked;
//   sphere         |p − c| < r, exactly as far as it matters (points within the bound of the
//                  surface were decided above): winding 1 or 0;
//   parity mesh    (MeshTopology::sign, closed and consistently oriented): the number of
//                  crossings of a ray from p, odd inside. Only the mesh's connected components
//                  whose boxes hold p count (mesh/components.h: a closed component adds an even
//                  number of crossings to any path between two points outside its box), so a
//                  point in no such box is outside with no ray, and a ray goes only as far as
//                  the boxes of the point's components (query/parity_pieces.h). The rays go
//                  through QueryEngine on the exact path (Mode::all, Precision::exact: the
//                  watertight double test, a crossing of a shared edge or vertex counted once, a
//                  tangent touch twice), along the line to the nearest surface point the short
//                  way out (away from that surface on the side its normal points to, through it
//                  from behind); every crossing on any ray from p is at least p's distance from
//                  the surface away, more than the rounding of any t. A ray that crosses an edge
//                  or a vertex of the mesh (a ray along a face's plane meets its edges) is cast
//                  again along two fixed directions, and if those also touch edges the three
//                  vote; winding 1 or 0;
//   winding mesh   the generalized winding number (QueryEngine::winding_number: fast winding
//                  numbers), inside where it is ≥ ½; a lone triangle encloses nothing.
// The scene's answer: inside any object; its winding number is the largest of the objects'.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/cancel.h"
#include "engine/query/intersect.h"

namespace raycastd::engine {

/// The nearest hits of a batch wherever the caller keeps them: hit i at `first` plus i·stride
/// bytes (query_points passes the hits inside its answers, rather than copying 1M of them).
class NearestHits {
  public:
    /// Hits in an array of their own.
    explicit NearestHits(const PointHit* first) : first_(reinterpret_cast<const char*>(first)) {}
    /// The hits that are member `hit` of each element of an array of T (explicit, so that a
    /// pointer into such an array cannot pass for an array of hits).
    template <class T>
    static NearestHits members(const T* first, PointHit T::*hit) {
        NearestHits h(first ? &(first->*hit) : nullptr);
        h.stride_ = sizeof(T);
        return h;
    }
    const PointHit& operator[](std::size_t i) const {
        return *reinterpret_cast<const PointHit*>(first_ + i * stride_);
    }

  private:
    const char* first_;
    std::size_t stride_ = sizeof(PointHit);
};

/// One point's classification.
struct Occupancy {
    bool inside = false;
    double winding = 0.0;
};

/// Classifies points[0..n), whose nearest surface points (any distance; !valid() for an empty
/// scene) are nearest[0..n), into out[0..n). `all_objects = false` (signed distance) stops at
/// the first object that contains the point (the winding then is not the largest). ok, or
/// Code::cancelled once `cancel` has fired (asked per block of points and by the parity rays).
/// The points are taken in `order` (batch.h's spatial_order; empty: as they come), which changes
/// no answer, only which points' rays and tree walks follow one another.
Status classify_points(const QueryEngine& engine, const Vec3d* points, NearestHits nearest,
                       std::size_t n, bool all_objects, const CancelToken& cancel, Occupancy* out,
                       const std::vector<std::uint32_t>& order = {});

/// Whether `nearest` puts its query point on a surface (within the distance's error bound).
inline bool on_surface(const PointHit& nearest) {
    return nearest.valid() && nearest.distance <= nearest.err;
}

}  // namespace raycastd::engine
