#include "server/schema/explain_doc.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <optional>
#include <vector>

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
        if (s.representable) {
            w.raw(",\"coefficients\":{\"a\":").number(s.a).raw(",\"b\":").number(s.b);
            w.raw(",\"c\":").number(s.c).raw("},\"discriminant\":").number(s.discriminant);
        } else {
            w.raw(",\"coefficients\":null,\"discriminant\":null,\"out_of_range\":true");
        }
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
        if (t.representable) {
            w.raw(",\"normal\":").vec(t.normal);
            w.raw(",\"plane\":{\"n\":").vec(t.normal).raw(",\"n_dot_a\":").number(t.plane_d);
            w.ch('}');
        } else {
            w.raw(",\"normal\":null,\"plane\":null,\"out_of_range\":true");
        }
        // t of the plane crossing, whether or not d is inside abc (null when parallel).
        w.raw(",\"t\":");
        if (t.t) {
            w.number(*t.t);
        } else {
            w.raw("null");
        }
        if (t.point)
            w.raw(",\"point\":").vec(*t.point);
        if (t.t && t.representable) {
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

// The Markdown form is read by students in GitHub and KaTeX renderers, so every rule below is
// about what those render correctly: prose stays outside math ($…$ holds only symbols and
// numbers), operators are LaTeX commands (\times, \langle n, x\rangle, \cdot), matrices with
// their \\ row breaks appear only in display math (GitHub's inline math has eaten \\ before),
// and names from the scene document are escaped so that a "$" or "*" in a name stays text.
namespace {

using engine::Vec3d;

/// A number for LaTeX: the shortest round-trip digits, "1e-05" as 1 \times 10^{-5}, and
/// \infty for infinities.
std::string tex_num(double v) {
    if (std::isinf(v))
        return v > 0 ? "\\infty" : "-\\infty";
    std::string s = format_shortest(v);
    const std::size_t e = s.find('e');
    if (e == std::string::npos)
        return s;
    const int exponent = std::stoi(s.substr(e + 1));
    const std::string mantissa = s.substr(0, e);
    return (mantissa == "1" ? "" : mantissa + " \\times ") + "10^{" + std::to_string(exponent) +
           "}";
}

/// Display-math column vector.
std::string tex_column(const Vec3d& v) {
    return "\\begin{pmatrix}" + tex_num(v.x) + "\\\\" + tex_num(v.y) + "\\\\" + tex_num(v.z) +
           "\\end{pmatrix}";
}

/// Inline-math row vector (no \\ inside inline math).
std::string tex_row(const Vec3d& v) {
    return "(" + tex_num(v.x) + ", " + tex_num(v.y) + ", " + tex_num(v.z) + ")";
}

/// Text from the scene document (object names, the engine's reasons) as Markdown prose.
std::string md_text(const std::string& s) {
    std::string out;
    for (char c : s) {
        if (c != '\0' && std::strchr("\\`*_[]<>#|$~", c) != nullptr)
            out += '\\';
        out += c;
    }
    return out;
}

/// One of the engine's equation steps ("(x-0)^2+(y-3)^2+(z-8)^2 = 2^2") in LaTeX, or nothing
/// when the line holds more than numbers, the unknowns x, y, z, t, operators and brackets (prose,
/// which the writer words itself from the structured fields instead of putting it in math).
std::optional<std::string> tex_equation(const std::string& step) {
    std::string out;
    for (std::size_t i = 0; i < step.size();) {
        const char c = step[i];
        if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
            // A number: digits, a point, an exponent; rewritten with tex_num.
            std::size_t j = i;
            while (j < step.size() &&
                   (std::isdigit(static_cast<unsigned char>(step[j])) || step[j] == '.'))
                ++j;
            if (j + 1 < step.size() && step[j] == 'e' &&
                (std::isdigit(static_cast<unsigned char>(step[j + 1])) || step[j + 1] == '-' ||
                 step[j + 1] == '+')) {
                j += 2;
                while (j < step.size() && std::isdigit(static_cast<unsigned char>(step[j])))
                    ++j;
            }
            const std::string num = tex_num(std::strtod(step.substr(i, j - i).c_str(), nullptr));
            // "10^{-6}^2" is a double superscript (KaTeX refuses it): bracket such a base.
            const bool raised = j < step.size() && step[j] == '^';
            out += raised && num.find_first_of("^ ") != std::string::npos ? "(" + num + ")" : num;
            i = j;
            continue;
        }
        if (c == '\0' || std::strchr("xyzt+-^()= ", c) == nullptr)
            return std::nullopt;
        out += c;
        ++i;
    }
    return out;
}

/// A double that is a decimal of at most 6 places (the coefficients of a question whose inputs
/// are integers or simple decimals: 0.1² is 0.010000000000000002 in double, read as 1/100).
/// Returns the numerator over 10^places; nothing when no such decimal lies within 1e-13·|v|.
struct Decimal {
    std::int64_t num = 0;
    int places = 0;
};

std::optional<Decimal> as_decimal(double v) {
    constexpr double kLimit = 1 << 30;  // so that B² − 4AC below stays inside int64
    double scale = 1;
    for (int places = 0; places <= 6; ++places, scale *= 10) {
        const double n = std::round(v * scale);
        if (std::abs(n) >= kLimit)
            return std::nullopt;
        if (std::abs(n / scale - v) <= 1e-13 * std::abs(v))
            return Decimal{static_cast<std::int64_t>(n), places};
    }
    return std::nullopt;
}

std::int64_t gcd(std::int64_t a, std::int64_t b) {
    return std::gcd(a < 0 ? -a : a, b < 0 ? -b : b);
}

/// p/q in lowest terms as LaTeX (an integer when q divides p).
std::string tex_fraction(std::int64_t p, std::int64_t q) {
    if (q < 0) {
        p = -p;
        q = -q;
    }
    const std::int64_t g = gcd(p, q);
    if (g > 1) {
        p /= g;
        q /= g;
    }
    if (q == 1)
        return std::to_string(p);
    return std::string(p < 0 ? "-" : "") + "\\frac{" + std::to_string(p < 0 ? -p : p) + "}{" +
           std::to_string(q) + "}";
}

/// Whether p/q, reduced, has a finite decimal expansion (q = 2^i·5^j): then the decimals shown
/// are already exact and an exact form adds nothing.
bool terminates(std::int64_t p, std::int64_t q) {
    q /= gcd(p, q);
    q = q < 0 ? -q : q;
    while (q % 2 == 0)
        q /= 2;
    while (q % 5 == 0)
        q /= 5;
    return q == 1;
}

/// The exact roots of A·t² + B·t + C = 0 as the tutorial writes them by hand,
/// t = (−B ± √(B² − 4AC)) / 2A with √D = k√m, m squarefree: `both` is "9 \pm \sqrt{3}", `each`
/// the roots in ascending order ("9 - \sqrt{3}", "9 + \sqrt{3}"). Empty when a coefficient is
/// not a simple decimal, when the decimals shown are already exact (rational roots that
/// terminate), or when the exact values disagree with the engine's roots (a safety net).
struct ExactRoots {
    std::string both;
    std::vector<std::string> each;
};

std::optional<ExactRoots> exact_roots(const engine::SphereWork& s) {
    const auto a = as_decimal(s.a), b = as_decimal(s.b), c = as_decimal(s.c);
    if (!a || !b || !c || a->num == 0 || s.roots.empty())
        return std::nullopt;
    // Common denominator 10^K: A', B', C' integers with A'·t² + B'·t + C' = 0.
    const int k = std::max({a->places, b->places, c->places});
    auto scaled = [k](const Decimal& d) {
        std::int64_t n = d.num;
        for (int i = d.places; i < k; ++i)
            n *= 10;
        return n;
    };
    const std::int64_t A = scaled(*a), B = scaled(*b), C = scaled(*c);
    if (std::abs(A) >= (1 << 30) || std::abs(B) >= (1 << 30) || std::abs(C) >= (1 << 30))
        return std::nullopt;
    const std::int64_t D = B * B - 4 * A * C;
    if (D < 0)
        return std::nullopt;
    // √D = root·√rest with rest squarefree (small factors by trial division; a large leftover
    // that is itself a square is folded in too).
    std::int64_t root = 1, rest = D;
    for (std::int64_t f = 2; f <= 100000 && f * f <= rest; ++f) {
        while (rest % (f * f) == 0) {
            rest /= f * f;
            root *= f;
        }
    }
    const auto r = static_cast<std::int64_t>(std::llround(std::sqrt(static_cast<double>(rest))));
    if (r * r == rest) {
        root *= r;
        rest = 1;
    }
    ExactRoots out;
    std::vector<double> values;
    if (rest == 1 || D == 0) {
        const std::int64_t lo = -B - root, hi = -B + root;  // over 2A
        if (terminates(lo, 2 * A) && terminates(hi, 2 * A))
            return std::nullopt;
        for (std::int64_t n :
             D == 0 ? std::vector<std::int64_t>{-B} : std::vector<std::int64_t>{lo, hi}) {
            out.each.push_back(tex_fraction(n, 2 * A));
            values.push_back(static_cast<double>(n) / static_cast<double>(2 * A));
        }
        std::sort(values.begin(), values.end());
        if (values.size() == 2 && A < 0)
            std::swap(out.each[0], out.each[1]);
        out.both =
            out.each.size() == 1 ? out.each[0] : out.each[0] + " \\text{ or } " + out.each[1];
    } else {
        // (−B ± root·√rest) / 2A, reduced by g = gcd(B, root, 2A); the sign moved to the top.
        std::int64_t p = -B, q = root, den = 2 * A;
        const std::int64_t g = gcd(gcd(p, q), den);
        p /= g;
        q /= g;
        den /= g;
        if (den < 0) {
            p = -p;
            den = -den;
        }
        const std::string surd =
            (q == 1 ? "" : std::to_string(q)) + "\\sqrt{" + std::to_string(rest) + "}";
        auto form = [&](const char* sign) {
            const std::string op = sign;
            const std::string top =
                (p == 0 ? (op == "+" ? "" : op + " ") : std::to_string(p) + " " + op + " ") + surd;
            return den == 1 ? top : "\\frac{" + top + "}{" + std::to_string(den) + "}";
        };
        out.both = form("\\pm");
        out.each = {form("-"), form("+")};
        const double sq = static_cast<double>(q) * std::sqrt(static_cast<double>(rest));
        values = {(static_cast<double>(p) - sq) / static_cast<double>(den),
                  (static_cast<double>(p) + sq) / static_cast<double>(den)};
    }
    if (values.size() != s.roots.size())
        return std::nullopt;
    for (std::size_t i = 0; i < values.size(); ++i) {
        if (std::abs(values[i] - s.roots[i]) > 1e-9 * std::max(1.0, std::abs(s.roots[i])))
            return std::nullopt;
    }
    return out;
}

/// A·t² + B·t + C = 0 written as a student would: "t^2 - 20t + 96 = 0".
std::string tex_quadratic(double a, double b, double c) {
    std::string s;
    auto term = [&s](double k, const char* var) {
        if (k == 0.0 && !s.empty())
            return;
        if (!s.empty())
            s += k < 0.0 ? " - " : " + ";
        else if (k < 0.0)
            s += "-";
        const double m = std::abs(k);
        if (*var == '\0' || m != 1.0)
            s += tex_num(m);
        s += var;
    };
    term(a, "t^2");
    term(b, "t");
    term(c, "");
    return s + " = 0";
}

/// Written in place of the algebra whose numbers leave double's range (engine/explain).
constexpr const char* kOutOfRangeMd =
    "At this scale the products of the coordinates leave double precision's range (about "
    "$10^{-308}$ to $1.8 \\cdot 10^{308}$), so the algebra is not written out: the engine's "
    "kernels rescale the coordinates by a power of two first.";

void write_sphere(std::string& md, const engine::ObjectWork& o,
                  std::vector<std::optional<std::string>>& exact_first) {
    const auto& s = *o.sphere;
    // The engine's equation lines: the sphere's equation, then l(t) substituted into it.
    std::vector<std::string> equations;
    for (const auto& step : o.steps) {
        if (!step.empty() && step[0] == '(') {
            if (auto tex = tex_equation(step))
                equations.push_back(*tex);
        }
    }
    if (!equations.empty())
        md += "The sphere's equation is\n\n$$" + equations[0] + "$$\n\n";
    if (equations.size() > 1)
        md += "Substituting $l(t)$ gives\n\n$$" + equations[1] + "$$\n\n";
    if (!s.representable) {
        md += std::string(kOutOfRangeMd);
        if (s.roots.empty()) {
            md += " They find no real root.\n\n";
        } else {
            md += s.roots.size() == 1
                      ? " They find one root (tangent), $t = " + tex_num(s.roots[0]) + "$.\n\n"
                      : " They find $t = " + tex_num(s.roots[0]) +
                            "$ or $t = " + tex_num(s.roots[1]) + "$.\n\n";
        }
        return;
    }
    md += "which is the quadratic $" + tex_quadratic(s.a, s.b, s.c) +
          "$ with $A = " + tex_num(s.a) + "$, $B = " + tex_num(s.b) + "$, $C = " + tex_num(s.c) +
          "$. ";
    md += "The discriminant is $B^2 - 4AC = " + tex_num(s.discriminant) + "$";
    if (s.roots.empty()) {
        md += ", which is negative: there are no real roots.\n\n";
        return;
    }
    const auto exact = exact_roots(s);
    if (s.roots.size() == 1) {
        md +=
            ", so the ray touches the sphere at one point (tangent): $t = " + tex_num(s.roots[0]) +
            "$";
    } else {
        md += ", so $t = " + tex_num(s.roots[0]) + "$ or $t = " + tex_num(s.roots[1]) + "$";
    }
    if (exact)
        md += " (exactly, $t = " + exact->both + "$)";
    md += ".\n\n";
    if (exact && o.hit && o.t) {
        for (std::size_t i = 0; i < s.roots.size(); ++i) {
            if (s.roots[i] == *o.t)
                exact_first[o.index] = exact->each[i];
        }
    }
}

void write_triangle(std::string& md, const engine::ObjectWork& o, const engine::Ray& ray,
                    std::vector<std::optional<std::string>>& exact_first) {
    const auto& t = *o.triangle;
    if (!t.representable) {
        md += std::string(kOutOfRangeMd) + " The watertight ray/triangle test " +
              (t.t ? "finds a hit at $t = " + tex_num(*t.t) + "$" : std::string("finds no hit")) +
              ".\n\n";
        return;
    }
    md += "The normal is $n = ac \\times ab = " + tex_row(t.normal) +
          "$ and the plane of the triangle is $\\langle n, x\\rangle = \\langle n, a\\rangle = " +
          tex_num(t.plane_d) + "$.\n\n";
    if (t.normal == Vec3d{0.0, 0.0, 0.0}) {
        md += "The normal is zero: the triangle is degenerate and is never hit.\n\n";
        return;
    }
    if (!t.t) {
        md += "Since $\\langle n, v\\rangle = 0$, the ray is parallel to the plane and misses.\n\n";
        return;
    }
    const double n_dot_p = engine::dot(t.normal, ray.origin);
    md +=
        "Substituting $l(t)$ into the plane gives $\\langle n, p\\rangle + t \\langle n, "
        "v\\rangle = \\langle n, a\\rangle$, so\n\n";
    md +=
        "$$t = \\frac{\\langle n, a\\rangle - \\langle n, p\\rangle}{\\langle n, v\\rangle} = "
        "\\frac{" +
        tex_num(t.plane_d) + " - " +
        (n_dot_p < 0 ? "(" + tex_num(n_dot_p) + ")" : tex_num(n_dot_p)) + "}{" +
        tex_num(t.n_dot_v) + "} = " + tex_num(*t.t) + "$$\n\n";
    const auto num = as_decimal(t.plane_d - n_dot_p), den = as_decimal(t.n_dot_v);
    if (num && den && den->num != 0) {
        std::int64_t p = num->num, q = den->num;
        for (int i = num->places; i < den->places; ++i)
            p *= 10;
        for (int i = den->places; i < num->places; ++i)
            q *= 10;
        const double exact = static_cast<double>(p) / static_cast<double>(q);
        if (!terminates(p, q) && std::abs(exact - *t.t) <= 1e-9 * std::max(1.0, std::abs(*t.t))) {
            md += "Exactly, $t = " + tex_fraction(p, q) + "$.\n\n";
            exact_first[o.index] = tex_fraction(p, q);
        }
    }
    md += "The point on the plane is\n\n$$d = l(" + tex_num(*t.t) + ") = " + tex_column(*t.point) +
          "$$\n\n";
    md += "The cross products are $da \\times db = " + tex_row(t.cross[0]) +
          "$, $db \\times dc = " + tex_row(t.cross[1]) +
          "$ and $dc \\times da = " + tex_row(t.cross[2]) + "$. ";
    md += t.same_direction ? "They point the same way, so $d$ is inside the triangle *abc*.\n\n"
                           : "They do not point the same way, so $d$ is outside the triangle "
                             "*abc*.\n\n";
}

}  // namespace

std::string write_explain_markdown(const engine::Explanation& ex, const engine::Ray& ray) {
    std::string md;
    md += "# Which object does the ray hit first?\n\n";
    md += "The ray is\n\n$$l(t) = " + tex_column(ray.origin) + " + t \\cdot " +
          tex_column(ray.direction) + "$$\n\n";
    std::vector<std::optional<std::string>> exact_first(ex.objects.size());
    for (const auto& o : ex.objects) {
        md += "## " + md_text(o.name) + " (" + kind_name(o.kind) + ")\n\n";
        if (o.sphere)
            write_sphere(md, o, exact_first);
        if (o.triangle)
            write_triangle(md, o, ray, exact_first);
        if (o.kind == engine::ObjectKind::mesh) {
            md += "A mesh of " + std::to_string(o.triangles) +
                  " triangles, too many to work by hand: each is tested with the watertight "
                  "ray/triangle test.\n\n";
        }
        if (o.hit && o.t) {
            md += "**Hit** at $t = " + tex_num(*o.t) + "$.\n\n";
        } else {
            std::string reason = o.reason.empty() ? "the ray misses" : o.reason;
            // The engine's reasons name tmin/tmax and <n,v> in plain text: words, kept as prose.
            md += "**Miss**: " + md_text(reason) + ".\n\n";
        }
    }
    md += "## Answer\n\n";
    if (ex.first_hit) {
        const auto& h = *ex.first_hit;
        const auto& exact = exact_first[h.object];
        md += "The smallest $t$ is $" + tex_num(h.t) + "$" +
              (exact ? " (exactly $" + *exact + "$)" : std::string()) +
              ", so the ray first hits **" + md_text(ex.objects[h.object].name) +
              "** at the point\n\n$$l(" + tex_num(h.t) + ") = " + tex_column(ex.first_point) +
              "$$\n";
    } else {
        md += "The ray hits nothing.\n";
    }
    return md;
}

}  // namespace raycastd::server
