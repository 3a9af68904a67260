#include "tests/stress/case_file.h"

#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "tests/stress/generators.h"

namespace raycastd::stress {

namespace {

std::string hex(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%a", v);
    return buf;
}
std::string hex(const engine::Vec3d& v) {
    return hex(v.x) + " " + hex(v.y) + " " + hex(v.z);
}

bool parse(std::istringstream& in, double& v) {
    std::string tok;
    if (!(in >> tok))
        return false;
    char* end = nullptr;
    v = std::strtod(tok.c_str(), &end);  // reads hex floats, decimals and inf
    return end && *end == '\0';
}
bool parse(std::istringstream& in, engine::Vec3d& v) {
    return parse(in, v.x) && parse(in, v.y) && parse(in, v.z);
}

}  // namespace

std::string write_case(const StressCase& c, const std::string& comment) {
    std::ostringstream out;
    std::istringstream lines(comment);
    for (std::string line; std::getline(lines, line);)
        out << "# " << line << "\n";
    for (std::size_t i = 0; i < c.scene->objects.size(); ++i) {
        const engine::Object& o = c.scene->objects[i];
        if (o.kind == engine::ObjectKind::sphere) {
            out << "sphere " << hex(o.sphere.center) << " " << hex(o.sphere.radius) << "\n";
            continue;
        }
        const engine::TriangleMesh& m = *o.mesh;
        if (o.kind == engine::ObjectKind::triangle) {
            const engine::Triangle t = m.triangle(0);
            out << "triangle " << hex(t.a) << " " << hex(t.b) << " " << hex(t.c) << "\n";
            continue;
        }
        const bool closed = i < c.closed.size() && c.closed[i];
        out << "mesh " << m.positions.size() << " " << m.size() << (closed ? " closed" : "")
            << "\n";
        for (const auto& p : m.positions)
            out << "v " << hex(p) << "\n";
        for (const auto& t : m.triangles)
            out << "f " << t[0] << " " << t[1] << " " << t[2] << "\n";
    }
    for (const engine::Ray& r : c.rays) {
        out << "ray " << hex(r.origin) << " " << hex(r.direction) << " " << hex(r.tmin) << " "
            << hex(r.tmax) << "\n";
    }
    return out.str();
}

bool read_case(const std::string& text, StressCase& out, std::string& error) {
    out.scene = std::make_shared<engine::Scene>(empty_scene());
    out.rays.clear();
    out.closed.clear();
    std::istringstream lines(text);
    std::string line;
    int line_no = 0;
    auto fail = [&](const std::string& why) {
        error = "line " + std::to_string(line_no) + ": " + why;
        return false;
    };
    while (std::getline(lines, line)) {
        ++line_no;
        std::istringstream in(line);
        std::string kind;
        if (!(in >> kind) || kind[0] == '#')
            continue;
        if (kind == "sphere") {
            engine::Vec3d c;
            double r = 0;
            if (!parse(in, c) || !parse(in, r))
                return fail("bad sphere");
            out.scene->objects.push_back(sphere(c, r));
            out.closed.push_back(false);
        } else if (kind == "triangle") {
            engine::Vec3d a, b, c;
            if (!parse(in, a) || !parse(in, b) || !parse(in, c))
                return fail("bad triangle");
            out.scene->objects.push_back(triangle(a, b, c));
            out.closed.push_back(false);
        } else if (kind == "mesh") {
            std::size_t nv = 0, nt = 0;
            std::string flag;
            if (!(in >> nv >> nt))
                return fail("bad mesh header");
            in >> flag;
            auto mesh = std::make_shared<engine::TriangleMesh>();
            for (std::size_t i = 0; i < nv + nt; ++i) {
                if (!std::getline(lines, line))
                    return fail("mesh cut short");
                ++line_no;
                std::istringstream ml(line);
                std::string tag;
                ml >> tag;
                if (i < nv) {
                    engine::Vec3d p;
                    if (tag != "v" || !parse(ml, p))
                        return fail("bad vertex");
                    mesh->positions.push_back(p);
                } else {
                    std::array<std::uint32_t, 3> t{};
                    if (tag != "f" || !(ml >> t[0] >> t[1] >> t[2]) || t[0] >= nv || t[1] >= nv ||
                        t[2] >= nv) {
                        return fail("bad face");
                    }
                    mesh->triangles.push_back(t);
                }
            }
            engine::Object o;
            o.kind = engine::ObjectKind::mesh;
            o.name = "mesh";
            o.mesh = std::move(mesh);
            out.scene->objects.push_back(std::move(o));
            out.closed.push_back(flag == "closed");
        } else if (kind == "ray") {
            engine::Ray r;
            if (!parse(in, r.origin) || !parse(in, r.direction) || !parse(in, r.tmin) ||
                !parse(in, r.tmax)) {
                return fail("bad ray");
            }
            out.rays.push_back(r);
        } else {
            return fail("unknown record '" + kind + "'");
        }
    }
    return true;
}

}  // namespace raycastd::stress
