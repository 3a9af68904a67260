#include "engine/query_types.h"

namespace raycastd::engine {

const char* to_string(Mode m) {
    switch (m) {
        case Mode::closest:
            return "closest";
        case Mode::any:
            return "any";
        case Mode::all:
            return "all";
        case Mode::count:
            return "count";
    }
    return "closest";
}

const char* to_string(Precision p) {
    switch (p) {
        case Precision::fast:
            return "fast";
        case Precision::refined:
            return "refined";
        case Precision::exact:
            return "exact";
    }
    return "exact";
}

}  // namespace raycastd::engine
