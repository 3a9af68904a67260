#include "bench/render/pov_writer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace raycastd::bench {

namespace {

using engine::Vec3d;

std::string vec(const Vec3d& v) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "<%.9g, %.9g, %.9g>", v.x, v.y, v.z);
    return buf;
}

std::string texture(const engine::Material& m) {
    // POV-Ray multiplies the ambient term by the pigment: ambient = ka / kd per channel.
    const auto ratio = [](double a, double d) { return d > 1e-6 ? a / d : a; };
    const Vec3d kd = m.diffuse;
    const Vec3d amb{ratio(m.ambient.x, kd.x), ratio(m.ambient.y, kd.y), ratio(m.ambient.z, kd.z)};
    const double ks = (m.specular.x + m.specular.y + m.specular.z) / 3.0;
    std::ostringstream os;
    os << "texture { pigment { rgbt <" << kd.x << ", " << kd.y << ", " << kd.z << ", "
       << m.transparency << "> } finish { diffuse 1 ambient rgb " << vec(amb) << " emission rgb "
       << vec(m.emissive);
    if (ks > 0)
        os << " phong " << ks << " phong_size " << std::max(1.0, m.shininess);
    if (m.reflectivity > 0)
        os << " reflection { " << m.reflectivity << " }";
    os << " } }";
    if (m.transparency > 0)
        os << " interior { ior " << m.ior << " }";
    return os.str();
}

void write_mesh(std::ostringstream& os, const engine::Scene& s, const engine::Object& o) {
    const engine::TriangleMesh& m = *o.mesh;
    const bool normals = m.normals.size() == m.positions.size();
    os << "mesh2 {\n  vertex_vectors { " << m.positions.size();
    for (const Vec3d& p : m.positions)
        os << ",\n    " << vec(p);
    os << " }\n";
    if (normals) {
        os << "  normal_vectors { " << m.normals.size();
        for (const auto& n : m.normals)
            os << ",\n    " << vec(Vec3d(n));
        os << " }\n";
    }
    const bool per_triangle = !m.triangle_material.empty();
    if (per_triangle) {
        os << "  texture_list { " << s.materials.size();
        for (const auto& mat : s.materials)
            os << ",\n    " << texture(mat);
        os << " }\n";
    }
    os << "  face_indices { " << m.triangles.size();
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        const auto& t = m.triangles[i];
        os << ",\n    <" << t[0] << ", " << t[1] << ", " << t[2] << ">";
        if (per_triangle)
            os << ", " << m.triangle_material[i];
    }
    os << " }\n";
    if (!per_triangle)
        os << "  " << texture(s.materials[o.material]) << "\n";
    os << "}\n";
}

}  // namespace

std::string to_pov(const engine::Scene& s, const engine::Camera& cam, int width, int height,
                   int max_depth) {
    std::ostringstream os;
    os.precision(9);
    Vec3d ambient = s.lights.empty() ? Vec3d{1, 1, 1} : Vec3d{};
    for (const auto& l : s.lights) {
        if (l.type == engine::LightType::ambient)
            ambient += l.intensity;
    }
    os << "#version 3.7;\n";
    os << "global_settings { assumed_gamma 1.0 max_trace_level " << max_depth
       << " ambient_light rgb " << vec(ambient) << " }\n";
    os << "background { rgb 0 }\n";
    const double up = 2.0 * std::tan(0.5 * cam.fov_y_deg * M_PI / 180.0);
    const double aspect = static_cast<double>(width) / height;
    os << "camera { perspective location " << vec(cam.position) << " sky " << vec(cam.up)
       << " direction <0, 0, 1> up <0, " << up << ", 0> right <" << -up * aspect
       << ", 0, 0> look_at " << vec(cam.look_at) << " }\n";
    const engine::Bounds3 b = s.bounds();
    const double far = 1e3 * (length(b.diagonal()) + 1.0);
    for (const auto& l : s.lights) {
        if (l.type == engine::LightType::point) {
            os << "light_source { " << vec(l.position) << " color rgb " << vec(l.intensity)
               << " }\n";
        } else if (l.type == engine::LightType::directional) {
            const Vec3d from = b.center() - normalize(l.direction) * far;
            os << "light_source { " << vec(from) << " color rgb " << vec(l.intensity)
               << " parallel point_at " << vec(b.center()) << " }\n";
        }
    }
    for (const auto& o : s.objects) {
        if (o.kind == engine::ObjectKind::sphere) {
            os << "sphere { " << vec(o.sphere.center) << ", " << o.sphere.radius << " "
               << texture(s.materials[o.material]) << " }\n";
        } else if (o.kind == engine::ObjectKind::triangle) {
            const engine::Triangle t = o.mesh->triangle(0);
            os << "triangle { " << vec(t.a) << ", " << vec(t.b) << ", " << vec(t.c) << " "
               << texture(
                      s.materials[o.mesh->triangle_material.empty() ? o.material
                                                                    : o.mesh->triangle_material[0]])
               << " }\n";
        } else {
            write_mesh(os, s, o);
        }
    }
    return os.str();
}

}  // namespace raycastd::bench
