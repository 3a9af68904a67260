#include "engine/accel/embree/device.h"

#include <cstdlib>
#include <string>

namespace raycastd::engine::embree {

namespace {

// The last error Embree reported on this thread; a build reads and clears it (take_error).
thread_local RTCError t_last_error = RTC_ERROR_NONE;
thread_local std::string t_last_message;

void on_embree_error(void*, RTCError code, const char* message) {
    t_last_error = code;
    t_last_message = message ? message : "";
}

}  // namespace

RTCDevice shared_device() {
    static RTCDevice device = [] {
        // RAYCASTD_EMBREE_CONFIG adds to Embree's configuration (rtcNewDevice(3)); it is not
        // checked here, and Embree ignores what it does not know. The tests run the Embree suites
        // again with "max_isa=avx2" (a cap: a processor without AVX2 keeps its own kernels),
        // whose kernels hand a packet of 16 to the hit filters in halves of 8 (lane i of the
        // second half is ray 8 + i), where AVX-512 kernels hand it over whole (docs/numerics.md).
        std::string config = "verbose=0";
        if (const char* extra = std::getenv("RAYCASTD_EMBREE_CONFIG"))
            config += std::string(",") + extra;
        RTCDevice d = rtcNewDevice(config.c_str());
        if (d)
            rtcSetDeviceErrorFunction(d, on_embree_error, nullptr);
        return d;
    }();
    return device;
}

Status take_error(const char* what) {
    const RTCError e = t_last_error;
    const std::string msg = t_last_message;
    t_last_error = RTC_ERROR_NONE;
    t_last_message.clear();
    if (e == RTC_ERROR_NONE)
        return {};
    const Code code = e == RTC_ERROR_OUT_OF_MEMORY ? Code::too_large : Code::internal;
    return Status::error(code, std::string(what) + ": Embree error " +
                                   std::to_string(static_cast<int>(e)) +
                                   (msg.empty() ? "" : " (" + msg + ")"));
}

}  // namespace raycastd::engine::embree
