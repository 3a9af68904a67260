// glTF 2.0 through load_model: the input is a .gltf (JSON) or, when it starts with the GLB
// magic "glTF", a .glb container; an external buffer reads as the input's resource part
// (fuzz_support.h). Every model returned must keep load_model's promises (check_model).

#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace raycastd;
    const fuzz::ModelInput in = fuzz::split_model_input(fuzz::bytes_of(data, size));
    const engine::ModelFormat format =
        in.model.substr(0, 4) == "glTF" ? engine::ModelFormat::glb : engine::ModelFormat::gltf;
    fuzz::load_and_check(in, format);
    return 0;
}
