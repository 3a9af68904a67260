// PLY, ASCII and binary (Turk, "The PLY Polygon File Format", 1994; as documented by Bourke,
// paulbourke.net/dataformats/ply).
//
// Read by hand, not through OpenMesh 9's PLY reader, which on hostile input can spin without
// end (its header loop waits for "end_header" without checking for end of stream), index an
// empty element list (a property before any element), push back as many list entries as a
// face line claims (a 30-byte ASCII file saying "4000000000 1 2 3" allocates gigabytes), keep
// per-file state in a process-wide singleton (concurrent loads race), and read coordinates
// only as float (int-typed coordinates become 0 with a message on std::cerr). Here every count
// is checked against the bytes that remain before anything is reserved or looped over.

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>

#include "engine/load/loaders.h"
#include "engine/load/text_scan.h"

namespace raycastd::engine::detail {

namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "binary PLY decoding assumes a little-endian host");

enum class Type { i8, u8, i16, u16, i32, u32, f32, f64 };

std::optional<Type> parse_type(std::string_view s) {
    if (s == "char" || s == "int8")
        return Type::i8;
    if (s == "uchar" || s == "uint8")
        return Type::u8;
    if (s == "short" || s == "int16")
        return Type::i16;
    if (s == "ushort" || s == "uint16")
        return Type::u16;
    if (s == "int" || s == "int32")
        return Type::i32;
    if (s == "uint" || s == "uint32")
        return Type::u32;
    if (s == "float" || s == "float32")
        return Type::f32;
    if (s == "double" || s == "float64")
        return Type::f64;
    return std::nullopt;
}

std::size_t type_size(Type t) {
    switch (t) {
        case Type::i8:
        case Type::u8:
            return 1;
        case Type::i16:
        case Type::u16:
            return 2;
        case Type::f64:
            return 8;
        default:
            return 4;
    }
}

bool is_integer(Type t) {
    return t != Type::f32 && t != Type::f64;
}

struct Property {
    std::string name;
    Type type = Type::f32;
    bool list = false;
    Type count_type = Type::u8;
};

struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Property> properties;
};

enum class Encoding { ascii, binary_le, binary_be };

struct Header {
    Encoding encoding = Encoding::ascii;
    std::vector<Element> elements;
    std::size_t data_offset = 0;
    std::size_t skipped_lines = 0;
};

/// "format <encoding> 1.0".
std::optional<Encoding> parse_format(const std::vector<std::string_view>& t) {
    if (t.size() != 3 || t[2] != "1.0")
        return std::nullopt;
    if (t[1] == "ascii")
        return Encoding::ascii;
    if (t[1] == "binary_little_endian")
        return Encoding::binary_le;
    if (t[1] == "binary_big_endian")
        return Encoding::binary_be;
    return std::nullopt;
}

/// "property <type> <name>" or "property list <count type> <value type> <name>".
std::optional<Property> parse_property(const std::vector<std::string_view>& t) {
    if (t.size() == 5 && t[1] == "list") {
        auto count_type = parse_type(t[2]), value_type = parse_type(t[3]);
        if (!count_type || !value_type || !is_integer(*count_type))
            return std::nullopt;
        return Property{std::string(t[4]), *value_type, true, *count_type};
    }
    auto value_type = t.size() == 3 ? parse_type(t[1]) : std::nullopt;
    if (!value_type)
        return std::nullopt;
    return Property{std::string(t[2]), *value_type, false, Type::u8};
}

Result<Header> parse_header(std::string_view bytes, std::string_view name) {
    LineReader lines(bytes);
    std::string_view line;
    auto error = [&](const std::string& what) {
        return load_error(name, "PLY header line " + std::to_string(lines.number()) + ": " + what);
    };
    if (!lines.next(line) || tokens(line, false) != std::vector<std::string_view>{"ply"}) {
        return load_error(name, "not a PLY file (first line is not 'ply')");
    }
    Header h;
    bool has_format = false;
    while (true) {
        if (!lines.next(line))
            return load_error(name, "PLY header has no end_header");
        auto t = tokens(line, false);
        if (t.empty() || t[0] == "comment" || t[0] == "obj_info")
            continue;
        if (t[0] == "end_header")
            break;
        if (t[0] == "format") {
            auto encoding = parse_format(t);
            if (!encoding)
                return error("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
            h.encoding = *encoding;
            has_format = true;
        } else if (t[0] == "element") {
            auto count = t.size() == 3 ? parse_int(t[2]) : std::nullopt;
            if (!count || *count < 0)
                return error("expected 'element <name> <count>'");
            h.elements.push_back({std::string(t[1]), static_cast<std::uint64_t>(*count), {}});
        } else if (t[0] == "property") {
            if (h.elements.empty())
                return error("property before any element");
            auto property = parse_property(t);
            if (!property)
                return error("malformed property");
            h.elements.back().properties.push_back(*property);
        } else {
            // Exporters write free text into headers (Blender 2.4: "Created by Blender3D
            // ..."); like most readers we pass over lines we do not understand.
            ++h.skipped_lines;
        }
    }
    if (!has_format)
        return load_error(name, "PLY header has no format line");
    h.data_offset = lines.position();
    return h;
}

/// Values of the data section, one at a time, from ASCII tokens or packed binary; every read
/// is bounds-checked and reports failure instead of reading past the end.
class Values {
  public:
    Values(std::string_view data, Encoding encoding) : data_(data), encoding_(encoding) {}

    bool read(Type t, double& out) {
        if (encoding_ == Encoding::ascii) {
            while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_])))
                ++pos_;
            const std::size_t start = pos_;
            while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_])))
                ++pos_;
            auto v = parse_double(data_.substr(start, pos_ - start));
            if (!v)
                return false;
            out = *v;
            return true;
        }
        const std::size_t n = type_size(t);
        if (data_.size() - pos_ < n)
            return false;
        unsigned char b[8];
        std::memcpy(b, data_.data() + pos_, n);
        pos_ += n;
        if (encoding_ == Encoding::binary_be)
            std::reverse(b, b + n);  // we run little-endian
        out = decode(t, b);
        return true;
    }
    /// Bytes not yet consumed: an upper bound on how many more values can follow.
    std::size_t remaining() const { return data_.size() - pos_; }

  private:
    static double decode(Type t, const unsigned char* b) {
        switch (t) {
            case Type::i8:
                return static_cast<std::int8_t>(b[0]);
            case Type::u8:
                return b[0];
            case Type::i16: {
                std::int16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case Type::u16: {
                std::uint16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case Type::i32: {
                std::int32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::u32: {
                std::uint32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::f32: {
                float v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::f64: {
                double v;
                std::memcpy(&v, b, 8);
                return v;
            }
        }
        return 0.0;
    }

    std::string_view data_;
    Encoding encoding_;
    std::size_t pos_ = 0;
};

bool is_face_list(const Property& p) {
    return p.list && (p.name == "vertex_indices" || p.name == "vertex_index");
}

class PlyReader {
  public:
    PlyReader(std::string_view name, const LoadLimits& limits) : name_(name), limits_(limits) {
        part_.name = std::string(name);
    }

    Result<LoadedModel> run(std::string_view bytes) {
        auto header = parse_header(bytes, name_);
        if (!header)
            return header.status();
        if (header->skipped_lines > 0) {
            model_.warnings.push_back(std::to_string(header->skipped_lines) +
                                      " unrecognised PLY header lines ignored");
        }
        Values values(bytes.substr(header->data_offset), header->encoding);
        for (const Element& e : header->elements) {
            // Every record takes at least one byte, so a larger count is a lie; checking it
            // first keeps a bogus header from driving a long loop or a huge reservation.
            if (e.count > values.remaining() || (e.count > 0 && e.properties.empty())) {
                return load_error(name_, "PLY element '" + e.name + "' claims " +
                                             std::to_string(e.count) +
                                             " records, more than the data can hold");
            }
            Status st = e.name == "vertex" ? read_vertices(e, values)
                        : e.name == "face" ? read_faces(e, values)
                                           : skip(e, values);
            if (!st.ok())
                return st;
        }
        return finish();
    }

  private:
    Status truncated(const Element& e, std::uint64_t i) {
        return load_error(name_, "PLY data ends or is malformed in element '" + e.name +
                                     "' record " + std::to_string(i));
    }

    /// Reads one list's length and checks it against the bytes left (each entry takes ≥ 1).
    bool read_list_length(const Property& p, Values& values, std::size_t& n) {
        double k;
        if (!values.read(p.count_type, k) || !(k >= 0.0) || k != std::floor(k) ||
            k > static_cast<double>(values.remaining()))
            return false;
        n = static_cast<std::size_t>(k);
        return true;
    }

    Status skip(const Element& e, Values& values) {
        double v;
        for (std::uint64_t i = 0; i < e.count; ++i) {
            for (const Property& p : e.properties) {
                std::size_t n = 1;
                if (p.list && !read_list_length(p, values, n))
                    return truncated(e, i);
                for (std::size_t k = 0; k < n; ++k) {
                    if (!values.read(p.type, v))
                        return truncated(e, i);
                }
            }
        }
        return {};
    }

    Status read_vertices(const Element& e, Values& values) {
        if (!part_.mesh.positions.empty())
            return load_error(name_, "PLY has two vertex elements");
        int xyz = 0, normal = 0;
        for (const Property& p : e.properties) {
            xyz += !p.list && (p.name == "x" || p.name == "y" || p.name == "z");
            normal += !p.list && (p.name == "nx" || p.name == "ny" || p.name == "nz");
        }
        if (xyz != 3)
            return load_error(name_, "PLY vertex element needs x, y and z properties");
        auto& mesh = part_.mesh;
        mesh.positions.reserve(e.count);
        if (normal == 3)
            mesh.normals.reserve(e.count);
        double v;
        for (std::uint64_t i = 0; i < e.count; ++i) {
            Vec3d p, n;
            for (const Property& prop : e.properties) {
                std::size_t count = 1;
                if (prop.list && !read_list_length(prop, values, count))
                    return truncated(e, i);
                for (std::size_t k = 0; k < count; ++k) {
                    if (!values.read(prop.type, v))
                        return truncated(e, i);
                    if (prop.list)
                        continue;
                    if (prop.name == "x")
                        p.x = v;
                    else if (prop.name == "y")
                        p.y = v;
                    else if (prop.name == "z")
                        p.z = v;
                    else if (prop.name == "nx")
                        n.x = v;
                    else if (prop.name == "ny")
                        n.y = v;
                    else if (prop.name == "nz")
                        n.z = v;
                }
            }
            mesh.positions.push_back(p);
            if (normal == 3)
                mesh.normals.push_back(Vec3f(n));
        }
        return {};
    }

    Status read_faces(const Element& e, Values& values) {
        if (std::none_of(e.properties.begin(), e.properties.end(), is_face_list)) {
            return load_error(name_, "PLY face element has no vertex_indices list");
        }
        double v;
        for (std::uint64_t i = 0; i < e.count; ++i) {
            for (const Property& p : e.properties) {
                std::size_t count = 1;
                if (p.list && !read_list_length(p, values, count))
                    return truncated(e, i);
                const bool indices = is_face_list(p);
                if (indices)
                    poly_.clear();
                for (std::size_t k = 0; k < count; ++k) {
                    if (!values.read(p.type, v))
                        return truncated(e, i);
                    if (!indices)
                        continue;
                    if (!(v >= 0.0) || v != std::floor(v) ||
                        v >= static_cast<double>(part_.mesh.positions.size())) {
                        return load_error(name_, "PLY face " + std::to_string(i) +
                                                     " refers to vertex " + std::to_string(v) +
                                                     ", but " +
                                                     std::to_string(part_.mesh.positions.size()) +
                                                     " vertices precede it");
                    }
                    poly_.push_back(static_cast<std::uint32_t>(v));
                }
                if (indices && add_fan(part_.mesh, poly_) == 0)
                    ++short_faces_;
            }
            if (part_.mesh.triangles.size() > limits_.max_triangles) {
                return Status::error(Code::too_large, std::string(name_) + ": more than " +
                                                          std::to_string(limits_.max_triangles) +
                                                          " triangles");
            }
        }
        return {};
    }

    Result<LoadedModel> finish() {
        if (short_faces_ > 0)
            model_.warnings.push_back(std::to_string(short_faces_) +
                                      " faces with fewer than 3 vertices skipped");
        model_.parts.push_back(std::move(part_));
        if (Status st = finish_model(model_, name_, limits_); !st.ok())
            return st;
        return std::move(model_);
    }

    std::string_view name_;
    const LoadLimits& limits_;
    LoadedModel model_;
    ModelPart part_;
    std::vector<std::uint32_t> poly_;
    std::size_t short_faces_ = 0;
};

}  // namespace

Result<LoadedModel> load_ply(std::string_view bytes, std::string_view name,
                             const LoadLimits& limits) {
    return PlyReader(name, limits).run(bytes);
}

}  // namespace raycastd::engine::detail
