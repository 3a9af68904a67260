#include "server/schema/explain_doc.h"

#include "server/schema/json_writer.h"

namespace raycastd::server {

namespace {

using engine::format_shortest;

const char* kind_name(engine::ObjectKind k) {
    switch (k) {
        case engine::ObjectKind::sphere:
            return "sphere";
        case engine::ObjectKind::triangle:
            return "triangle";
        case engine::ObjectKind::mesh:
            return "mesh";
    }
    return "mesh";
}

void write_object(JsonWriter& w, const engine::ObjectWork& o) {
    w.raw("{\"index\":").integer(o.index);
    w.raw(",\"name\":").string(o.name);
    w.raw(",\"type\":").string(kind_name(o.kind));
    w.raw(",\"steps\":[");
    for (std::size_t i = 0; i < o.steps.size(); ++i) {
        if (i)
            w.ch(',');
        w.string(o.steps[i]);
    }
    w.ch(']');
    if (o.sphere) {
        const auto& s = *o.sphere;
        w.raw(",\"coefficients\":{\"a\":").number(s.a).raw(",\"b\":").number(s.b);
        w.raw(",\"c\":").number(s.c).raw("},\"discriminant\":").number(s.discriminant);
        w.raw(",\"roots\":[");
        for (std::size_t i = 0; i < s.roots.size(); ++i) {
            if (i)
                w.ch(',');
            w.number(s.roots[i]);
        }
        w.ch(']');
    }
    if (o.triangle) {
        const auto& t = *o.triangle;
        w.raw(",\"normal\":").vec(t.normal);
        w.raw(",\"plane\":{\"n\":").vec(t.normal).raw(",\"n_dot_a\":").number(t.plane_d).ch('}');
        // t of the plane crossing, whether or not d is inside abc (null when parallel).
        w.raw(",\"t\":");
        if (t.t) {
            w.number(*t.t);
        } else {
            w.raw("null");
        }
        if (t.point)
            w.raw(",\"point\":").vec(*t.point);
        if (t.t) {
            w.raw(",\"cross_products\":[").vec(t.cross[0]).ch(',').vec(t.cross[1]).ch(',');
            w.vec(t.cross[2]).ch(']');
            w.raw(",\"same_direction\":").boolean(t.same_direction);
        }
    }
    if (o.kind == engine::ObjectKind::mesh)
        w.raw(",\"triangles\":").integer(o.triangles);
    w.raw(",\"hit\":").boolean(o.hit);
    if (o.t && !o.triangle)
        w.raw(",\"t\":").number(*o.t);
    if (!o.hit)
        w.raw(",\"reason\":").string(o.reason);
    w.ch('}');
}

}  // namespace

std::string write_explain_json(const engine::Explanation& ex, const engine::Ray& ray) {
    std::string out;
    JsonWriter w(out);
    w.raw("{\"ray\":{\"origin\":").vec(ray.origin).raw(",\"direction\":").vec(ray.direction);
    w.raw(",\"tmin\":").number(ray.tmin).raw(",\"tmax\":").number(ray.tmax).raw("},\"objects\":[");
    for (std::size_t i = 0; i < ex.objects.size(); ++i) {
        if (i)
            w.ch(',');
        write_object(w, ex.objects[i]);
    }
    w.raw("],\"first_hit\":");
    if (ex.first_hit) {
        const auto& h = *ex.first_hit;
        w.raw("{\"object\":").integer(h.object);
        w.raw(",\"name\":").string(ex.objects[h.object].name);
        w.raw(",\"primitive\":").integer(h.primitive);
        w.raw(",\"t\":").number(h.t).raw(",\"point\":").vec(ex.first_point);
        w.raw(",\"normal\":").vec(h.normal).ch('}');
    } else {
        w.raw("null");
    }
    w.ch('}');
    return out;
}

namespace {

std::string tex_vec(const engine::Vec3d& v) {
    return "\\begin{pmatrix}" + format_shortest(v.x) + "\\\\" + format_shortest(v.y) + "\\\\" +
           format_shortest(v.z) + "\\end{pmatrix}";
}

}  // namespace

std::string write_explain_markdown(const engine::Explanation& ex, const engine::Ray& ray) {
    std::string md;
    md += "# Which object does the ray hit first?\n\n";
    md += "The ray is\n\n$$l(t) = " + tex_vec(ray.origin) + " + t \\cdot " +
          tex_vec(ray.direction) + "$$\n\n";
    for (const auto& o : ex.objects) {
        md += "## " + o.name + " (" + kind_name(o.kind) + ")\n\n";
        for (const auto& s : o.steps)
            md += "- $" + s + "$\n";
        md += "\n";
        if (o.sphere) {
            const auto& s = *o.sphere;
            md += "Coefficients $A = " + format_shortest(s.a) + "$, $B = " + format_shortest(s.b) +
                  "$, $C = " + format_shortest(s.c) +
                  "$; discriminant $B^2 - 4AC = " + format_shortest(s.discriminant) + "$.\n\n";
        }
        if (o.triangle && o.triangle->t) {
            md += "The cross products $da \\times db$, $db \\times dc$, $dc \\times da$ ";
            md += o.triangle->same_direction
                      ? "point the same way: $d$ is inside $abc$.\n\n"
                      : "do not point the same way: $d$ is outside $abc$.\n\n";
        }
        md += o.hit ? "**Hit** at $t = " + format_shortest(*o.t) + "$.\n\n"
                    : "**Miss**: " + o.reason + ".\n\n";
    }
    md += "## Answer\n\n";
    if (ex.first_hit) {
        const auto& h = *ex.first_hit;
        md += "The smallest $t$ is $" + format_shortest(h.t) + "$, so the ray first hits **" +
              ex.objects[h.object].name + "** at $l(" + format_shortest(h.t) +
              ") = " + tex_vec(ex.first_point) + "$.\n";
    } else {
        md += "The ray hits nothing.\n";
    }
    return md;
}

}  // namespace raycastd::server
