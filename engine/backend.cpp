#include "engine/backend.h"

#include <embree3/rtcore_config.h>

namespace raycastd::engine {

std::string backend_version() {
    return RTC_VERSION_STRING;
}

}  // namespace raycastd::engine
