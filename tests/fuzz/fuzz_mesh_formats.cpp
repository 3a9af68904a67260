// Our own OBJ, PLY, STL and OFF readers through load_model: the first byte picks the format
// (mod 4: obj, ply, stl, off) and the rest is the file, an OBJ's mtllib reading as the input's
// resource part (fuzz_support.h). Every model returned must keep load_model's promises.

#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace raycastd;
    if (size == 0)
        return 0;
    constexpr engine::ModelFormat kFormats[] = {engine::ModelFormat::obj, engine::ModelFormat::ply,
                                                engine::ModelFormat::stl, engine::ModelFormat::off};
    const engine::ModelFormat format = kFormats[data[0] % 4];
    const fuzz::ModelInput in = fuzz::split_model_input(fuzz::bytes_of(data + 1, size - 1));
    fuzz::load_and_check(in, format);
    return 0;
}
