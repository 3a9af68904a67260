#pragma once
// The Embree device every accelerator of the process shares, Embree's errors as Status values,
// and RAII handles for the scenes and geometries made on it.
//
// Embree reports errors through a device callback; its tutorials print them and go on. Ours
// records the last one per thread, and the build that caused it turns it into a Status with
// take_error(): RTC_ERROR_OUT_OF_MEMORY → too_large, anything else → internal. Nothing is
// printed, and a failed build leaves nothing behind (the handles release what was made).

#include <memory>

#include <embree3/rtcore.h>

#include "engine/status.h"

namespace raycastd::engine::embree {

/// The process's device ("verbose=0", errors recorded per thread), created on first use and
/// kept for the life of the process; nullptr when Embree cannot create one.
RTCDevice shared_device();

/// The error Embree last reported on this thread, as a Status whose message says `what` was
/// being done; ok when there was none. Clears the record, so take_error("") starts a build clean.
Status take_error(const char* what);

/// Releases an RTCScene (Embree counts references: a scene goes when nobody holds it).
struct SceneRelease {
    void operator()(RTCScene s) const { rtcReleaseScene(s); }
};
/// Releases an RTCGeometry.
struct GeometryRelease {
    void operator()(RTCGeometry g) const { rtcReleaseGeometry(g); }
};
/// An RTCScene that is released with its handle.
using SceneHandle = std::unique_ptr<RTCSceneTy, SceneRelease>;
/// An RTCGeometry that is released with its handle; a scene it is attached to holds a reference
/// of its own, so the handle may go once the geometry is attached.
using GeometryHandle = std::unique_ptr<RTCGeometryTy, GeometryRelease>;

}  // namespace raycastd::engine::embree
