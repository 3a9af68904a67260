#pragma once
// The resident memory of this process, for what reports it: the server's metrics and scene
// info, the benches' memory probes, the tests of memory that is given back.

#include <cstddef>
#include <fstream>

#if defined(__unix__)
#include <unistd.h>
#endif

namespace raycastd::engine {

/// This process's resident set size in bytes, from /proc/self/statm (its second field, in
/// pages); 0 where there is no such file.
inline std::size_t process_resident_bytes() {
    std::ifstream f("/proc/self/statm");
    std::size_t pages_total = 0, pages_resident = 0;
    if (!(f >> pages_total >> pages_resident))
        return 0;
#if defined(__unix__)
    const long page = ::sysconf(_SC_PAGESIZE);
#else
    const long page = 4096;
#endif
    return pages_resident * static_cast<std::size_t>(page > 0 ? page : 4096);
}

}  // namespace raycastd::engine
