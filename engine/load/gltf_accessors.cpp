// glTF accessors: bounds validation and decoding (glTF 2.0 §3.6 "Binary Data Storage").
//
// Every byte range is checked once, up front, in validate_buffers(); the readers below then
// index only inside ranges proven to lie within their buffer. Reads go through memcpy, so
// misaligned data (legal for sparse parts, and common in the wild) is never dereferenced as
// a typed pointer.

#include <algorithm>
#include <cstring>

#include "engine/load/gltf_internal.h"

namespace raycastd::engine::gltf {

namespace {

// glTF binary data is little-endian (glTF 2.0 §3.6.2.2); we decode it with memcpy.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "glTF decoding assumes a little-endian host");

Status fail(std::string msg) {
    return Status::error(Code::model_load_failed, std::move(msg));
}

// Overflow-checked size arithmetic; false when the exact result does not fit in size_t.
bool checked_add(std::size_t a, std::size_t b, std::size_t& out) {
    return !__builtin_add_overflow(a, b, &out);
}
bool checked_mul(std::size_t a, std::size_t b, std::size_t& out) {
    return !__builtin_mul_overflow(a, b, &out);
}

/// Size in bytes of one component; 0 for types glTF 2.0 does not allow in accessors (INT 5124
/// and DOUBLE 5130 are OpenGL types that glTF excludes, §3.6.2.2).
std::size_t component_size(int component_type) {
    switch (component_type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            return 2;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
            return 4;
        default:
            return 0;
    }
}

int component_count(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR:
            return 1;
        case TINYGLTF_TYPE_VEC2:
            return 2;
        case TINYGLTF_TYPE_VEC3:
            return 3;
        case TINYGLTF_TYPE_VEC4:
        case TINYGLTF_TYPE_MAT2:
            return 4;
        case TINYGLTF_TYPE_MAT3:
            return 9;
        case TINYGLTF_TYPE_MAT4:
            return 16;
        default:
            return 0;
    }
}

/// Bytes from one element to the next when tightly packed. Matrix columns start on 4-byte
/// boundaries, which pads MAT2 and MAT3 of 1-byte components and MAT3 of 2-byte components
/// (glTF 2.0 §3.6.2.4).
std::size_t element_size(int type, std::size_t csize) {
    if (type == TINYGLTF_TYPE_MAT2 && csize == 1)
        return 8;
    if (type == TINYGLTF_TYPE_MAT3 && csize == 1)
        return 12;
    if (type == TINYGLTF_TYPE_MAT3 && csize == 2)
        return 24;
    return static_cast<std::size_t>(component_count(type)) * csize;
}

/// Bytes the last element needs: its final column carries no padding after it (the
/// glTF-Validator's ACCESSOR_TOO_LONG rule counts it so).
std::size_t last_element_size(int type, std::size_t csize) {
    if (type == TINYGLTF_TYPE_MAT2 && csize == 1)
        return 6;
    if (type == TINYGLTF_TYPE_MAT3 && csize == 1)
        return 11;
    if (type == TINYGLTF_TYPE_MAT3 && csize == 2)
        return 22;
    return element_size(type, csize);
}

/// True when [offset, offset + (count − 1)·stride + size) fits in `length` bytes; count ≥ 1.
bool range_fits(std::size_t offset, std::size_t count, std::size_t stride, std::size_t size,
                std::size_t length) {
    std::size_t span, end;
    return checked_mul(count - 1, stride, span) && checked_add(offset, span, end) &&
           checked_add(end, size, end) && end <= length;
}

/// An accessor without a bufferView is all zeros (plus sparse values), so its count is bounded
/// by no byte range; this cap keeps a four-byte JSON number from allocating gigabytes.
constexpr std::size_t kMaxElementsWithoutBufferView = std::size_t{1} << 22;

std::string accessor_path(std::size_t i) {
    return "/accessors/" + std::to_string(i);
}

Status validate_buffer_view_ref(const tinygltf::Model& model, int view, const std::string& where) {
    if (view < 0 || static_cast<std::size_t>(view) >= model.bufferViews.size()) {
        return fail(where + " refers to bufferView " + std::to_string(view) +
                    ", but the file has " + std::to_string(model.bufferViews.size()));
    }
    return {};
}

Status validate_sparse(const tinygltf::Model& model, const tinygltf::Accessor& a, std::size_t i,
                       std::size_t esize) {
    const std::string where = accessor_path(i) + "/sparse";
    const auto& s = a.sparse;
    if (s.count < 1 || static_cast<std::size_t>(s.count) > a.count) {
        return fail(where + "/count is " + std::to_string(s.count) + ", outside 1.." +
                    std::to_string(a.count));
    }
    const auto n = static_cast<std::size_t>(s.count);
    if (Status st = validate_buffer_view_ref(model, s.indices.bufferView, where + "/indices");
        !st.ok()) {
        return st;
    }
    if (Status st = validate_buffer_view_ref(model, s.values.bufferView, where + "/values");
        !st.ok()) {
        return st;
    }
    const std::size_t isize = component_size(s.indices.componentType);
    if (s.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
        s.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
        s.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT || isize == 0) {
        return fail(where + "/indices/componentType " + std::to_string(s.indices.componentType) +
                    " is not an unsigned integer type");
    }
    if (s.indices.byteOffset < 0 || s.values.byteOffset < 0) {
        return fail(where + ": negative byteOffset");
    }
    const auto& iv = model.bufferViews[static_cast<std::size_t>(s.indices.bufferView)];
    const auto& vv = model.bufferViews[static_cast<std::size_t>(s.values.bufferView)];
    // Sparse indices and values are tightly packed (glTF 2.0 §3.6.2.3).
    if (!range_fits(static_cast<std::size_t>(s.indices.byteOffset), n, isize, isize,
                    iv.byteLength)) {
        return fail(where + "/indices: " + std::to_string(n) + " indices run past the end of " +
                    "bufferView " + std::to_string(s.indices.bufferView));
    }
    if (!range_fits(static_cast<std::size_t>(s.values.byteOffset), n, esize, esize,
                    vv.byteLength)) {
        return fail(where + "/values: " + std::to_string(n) + " values run past the end of " +
                    "bufferView " + std::to_string(s.values.bufferView));
    }
    return {};
}

Status validate_accessor(const tinygltf::Model& model, std::size_t i) {
    const tinygltf::Accessor& a = model.accessors[i];
    const std::string where = accessor_path(i);
    const std::size_t csize = component_size(a.componentType);
    if (csize == 0) {
        return fail(where + "/componentType " + std::to_string(a.componentType) +
                    " is not a glTF 2.0 component type");
    }
    if (component_count(a.type) == 0)
        return fail(where + "/type is not a glTF 2.0 type");
    const std::size_t esize = element_size(a.type, csize);
    if (a.bufferView != -1) {
        if (Status st = validate_buffer_view_ref(model, a.bufferView, where); !st.ok())
            return st;
        const auto& view = model.bufferViews[static_cast<std::size_t>(a.bufferView)];
        if (view.byteStride != 0 && view.byteStride < esize) {
            return fail(where + ": bufferView " + std::to_string(a.bufferView) + " byteStride " +
                        std::to_string(view.byteStride) + " is smaller than one element (" +
                        std::to_string(esize) + " bytes)");
        }
        const std::size_t stride = view.byteStride != 0 ? view.byteStride : esize;
        if (a.count > 0 && !range_fits(a.byteOffset, a.count, stride,
                                       last_element_size(a.type, csize), view.byteLength)) {
            return fail(where + ": " + std::to_string(a.count) + " elements of " +
                        std::to_string(esize) + " bytes (stride " + std::to_string(stride) +
                        ", byteOffset " + std::to_string(a.byteOffset) +
                        ") run past the end of bufferView " + std::to_string(a.bufferView) + " (" +
                        std::to_string(view.byteLength) + " bytes)");
        }
    } else if (a.count > kMaxElementsWithoutBufferView) {
        return fail(where + ": " + std::to_string(a.count) +
                    " elements without a bufferView is more than this loader accepts (" +
                    std::to_string(kMaxElementsWithoutBufferView) + ")");
    }
    if (a.sparse.isSparse)
        return validate_sparse(model, a, i, esize);
    return {};
}

/// One component at p, as a double. Normalized integers map to [0, 1] or [−1, 1] by the
/// equations of glTF 2.0 §3.11 (e.g. f = max(c / 127, −1) for signed bytes).
double decode_component(const unsigned char* p, int component_type, bool normalized) {
    switch (component_type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            std::int8_t v;
            std::memcpy(&v, p, 1);
            return normalized ? std::max(v / 127.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
            std::uint8_t v;
            std::memcpy(&v, p, 1);
            return normalized ? v / 255.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            std::int16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? std::max(v / 32767.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            std::uint16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? v / 65535.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            std::uint32_t v;
            std::memcpy(&v, p, 4);
            return normalized ? v / 4294967295.0 : v;
        }
        default: {  // FLOAT; validate_buffers() admits no other type
            float v;
            std::memcpy(&v, p, 4);
            return v;
        }
    }
}

std::uint32_t decode_index(const unsigned char* p, int component_type) {
    switch (component_type) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return p[0];
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            std::uint16_t v;
            std::memcpy(&v, p, 2);
            return v;
        }
        default: {
            std::uint32_t v;
            std::memcpy(&v, p, 4);
            return v;
        }
    }
}

/// Start of the bytes of a bufferView; validate_buffers() proved the whole view lies inside
/// its buffer.
const unsigned char* view_data(const tinygltf::Model& model, int view) {
    const auto& v = model.bufferViews[static_cast<std::size_t>(view)];
    return model.buffers[static_cast<std::size_t>(v.buffer)].data.data() + v.byteOffset;
}

Result<const tinygltf::Accessor*> find_accessor(const tinygltf::Model& model, int index,
                                                const std::string& what) {
    if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size()) {
        return fail(what + " refers to accessor " + std::to_string(index) + ", but the file has " +
                    std::to_string(model.accessors.size()));
    }
    return &model.accessors[static_cast<std::size_t>(index)];
}

}  // namespace

Status validate_buffers(const tinygltf::Model& model) {
    for (std::size_t i = 0; i < model.bufferViews.size(); ++i) {
        const auto& v = model.bufferViews[i];
        const std::string where = "/bufferViews/" + std::to_string(i);
        if (v.buffer < 0 || static_cast<std::size_t>(v.buffer) >= model.buffers.size()) {
            return fail(where + " refers to buffer " + std::to_string(v.buffer) +
                        ", but the file has " + std::to_string(model.buffers.size()));
        }
        const std::size_t size = model.buffers[static_cast<std::size_t>(v.buffer)].data.size();
        if (v.byteOffset > size || v.byteLength > size - v.byteOffset) {
            return fail(where + " (byteOffset " + std::to_string(v.byteOffset) + ", byteLength " +
                        std::to_string(v.byteLength) + ") runs past the end of buffer " +
                        std::to_string(v.buffer) + " (" + std::to_string(size) + " bytes)");
        }
    }
    for (std::size_t i = 0; i < model.accessors.size(); ++i) {
        if (Status st = validate_accessor(model, i); !st.ok())
            return st;
    }
    return {};
}

Result<std::vector<double>> read_floats(const tinygltf::Model& model, int index, int components,
                                        const std::string& what) {
    auto found = find_accessor(model, index, what);
    if (!found)
        return found.status();
    const tinygltf::Accessor& a = **found;
    if (component_count(a.type) != components || a.type == TINYGLTF_TYPE_MAT2) {
        return fail(what + " (accessor " + std::to_string(index) + ") must have " +
                    std::to_string(components) + " components");
    }
    const auto n = static_cast<std::size_t>(components);
    const std::size_t csize = component_size(a.componentType);
    const std::size_t esize = element_size(a.type, csize);
    std::vector<double> out(a.count * n, 0.0);
    if (a.bufferView != -1) {
        const auto& view = model.bufferViews[static_cast<std::size_t>(a.bufferView)];
        const std::size_t stride = view.byteStride != 0 ? view.byteStride : esize;
        const unsigned char* base = view_data(model, a.bufferView) + a.byteOffset;
        for (std::size_t e = 0; e < a.count; ++e) {
            for (std::size_t c = 0; c < n; ++c) {
                out[e * n + c] =
                    decode_component(base + e * stride + c * csize, a.componentType, a.normalized);
            }
        }
    }
    if (a.sparse.isSparse) {
        // Sparse substitution: element indices[k] takes values[k] (glTF 2.0 §3.6.2.3).
        const auto& s = a.sparse;
        const std::size_t isize = component_size(s.indices.componentType);
        const unsigned char* idx =
            view_data(model, s.indices.bufferView) + static_cast<std::size_t>(s.indices.byteOffset);
        const unsigned char* val =
            view_data(model, s.values.bufferView) + static_cast<std::size_t>(s.values.byteOffset);
        for (std::size_t k = 0; k < static_cast<std::size_t>(s.count); ++k) {
            const std::uint32_t target = decode_index(idx + k * isize, s.indices.componentType);
            if (target >= a.count) {
                return fail(accessor_path(static_cast<std::size_t>(index)) + "/sparse: index " +
                            std::to_string(target) + " is past the accessor's " +
                            std::to_string(a.count) + " elements");
            }
            for (std::size_t c = 0; c < n; ++c) {
                out[target * n + c] =
                    decode_component(val + k * esize + c * csize, a.componentType, a.normalized);
            }
        }
    }
    return out;
}

Result<std::vector<std::uint32_t>> read_indices(const tinygltf::Model& model, int index,
                                                const std::string& what) {
    auto found = find_accessor(model, index, what);
    if (!found)
        return found.status();
    const tinygltf::Accessor& a = **found;
    const bool unsigned_int = a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                              a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
                              a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    if (a.type != TINYGLTF_TYPE_SCALAR || !unsigned_int || a.normalized) {
        return fail(what + " (accessor " + std::to_string(index) +
                    ") must be a SCALAR of unsigned byte, short or int");
    }
    // Decoding through doubles is exact for every unsigned int, and shares the sparse path.
    auto values = read_floats(model, index, 1, what);
    if (!values)
        return values.status();
    std::vector<std::uint32_t> out(values->size());
    std::transform(values->begin(), values->end(), out.begin(),
                   [](double v) { return static_cast<std::uint32_t>(v); });
    return out;
}

}  // namespace raycastd::engine::gltf
