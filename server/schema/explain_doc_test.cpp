#include "server/schema/explain_doc.h"

#include <cctype>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"

namespace raycastd::server {
namespace {

/// The words inside $…$ / $$…$$ of a Markdown text: runs of 3+ ASCII letters that are neither a
/// LaTeX command (\sqrt) nor the argument of \text{}, \begin{} or \end{}. GitHub and KaTeX set
/// such a run as a product of italic variables, which is how "discriminant" once rendered.
std::vector<std::string> words_in_math(const std::string& md) {
    std::vector<std::string> words;
    bool in_math = false;
    for (std::size_t i = 0; i < md.size(); ++i) {
        const char c = md[i];
        if (c == '\\' && !in_math && i + 1 < md.size()) {
            ++i;  // an escaped character in prose, "\$" included
            continue;
        }
        if (c == '$') {
            if (i + 1 < md.size() && md[i + 1] == '$')
                ++i;
            in_math = !in_math;
            continue;
        }
        if (!in_math)
            continue;
        if (c == '\\') {
            std::size_t j = i + 1;
            while (j < md.size() && std::isalpha(static_cast<unsigned char>(md[j])))
                ++j;
            const std::string command = md.substr(i + 1, j - i - 1);
            if ((command == "text" || command == "begin" || command == "end") && j < md.size() &&
                md[j] == '{')
                j = md.find('}', j);
            i = j == std::string::npos ? md.size() : j - 1;
            continue;
        }
        std::size_t j = i;
        while (j < md.size() && std::isalpha(static_cast<unsigned char>(md[j])))
            ++j;
        if (j - i >= 3)
            words.push_back(md.substr(i, j - i));
        if (j > i)
            i = j - 1;
    }
    return words;
}

std::string markdown(const engine::Scene& scene, const engine::Ray& ray) {
    return write_explain_markdown(engine::explain(scene, ray).value(), ray);
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

TEST(ExplainMarkdown, CheckerFindsWordsInMath) {
    EXPECT_EQ(words_in_math("$discriminant B^2-4AC = 16$"),
              (std::vector<std::string>{"discriminant"}));
    EXPECT_EQ(words_in_math("$t = 8 or t = 12$ and prose"), (std::vector<std::string>{}));
    EXPECT_EQ(words_in_math(
                  "$t = 8 \\text{ or } t = 12$, $\\sqrt{3}$, $$\\begin{pmatrix}1\\end{pmatrix}$$"),
              (std::vector<std::string>{}));
    EXPECT_EQ(words_in_math("\\$5 and $abc$"), (std::vector<std::string>{"abc"}));
}

// The tutorial's Question 1: prose outside math, the discriminant and roots as the tutorial
// writes them, and the exact roots 9 ± √3 of the third sphere beside the decimals.
TEST(ExplainMarkdown, TutorialQuestion1) {
    const std::string md = markdown(engine::testing::tutorial_spheres(), {{0, 0, 0}, {0, 0, 1}});
    EXPECT_EQ(words_in_math(md), (std::vector<std::string>{})) << md;
    EXPECT_TRUE(contains(md, "$$(0-0)^2+(0-0)^2+(t-10)^2 = 2^2$$")) << md;
    EXPECT_TRUE(contains(md, "quadratic $t^2 - 20t + 96 = 0$")) << md;
    EXPECT_TRUE(contains(md, "The discriminant is $B^2 - 4AC = 16$, so $t = 8$ or $t = 12$."))
        << md;
    EXPECT_TRUE(contains(md, "(exactly, $t = 9 \\pm \\sqrt{3}$)")) << md;
    EXPECT_TRUE(contains(md, "there are no real roots")) << md;
    EXPECT_TRUE(contains(md, "The smallest $t$ is $7.267949192431123$ (exactly $9 - \\sqrt{3}$)"))
        << md;
    EXPECT_TRUE(contains(md, "**sphere 3**")) << md;
    // Integer roots that the decimals already give exactly get no "exactly".
    EXPECT_FALSE(contains(md, "\\pm 2")) << md;
}

// Question 3's plane method with the tutorial's notation: \times and \langle n, x\rangle, the
// triangle's name in prose, and t = 1/3 given as a fraction beside its decimals.
TEST(ExplainMarkdown, TriangleUsesTimesAndAngleBrackets) {
    engine::Scene s;
    s.materials.push_back(engine::Material{});
    s.objects.push_back(
        engine::testing::mesh_object("abc", {{0, 0, 1}, {2, 0, 1}, {0, 2, 1}}, {{0, 1, 2}}));
    const std::string md = markdown(s, {{0.5, 0.5, 0}, {0, 0, 3}});
    EXPECT_EQ(words_in_math(md), (std::vector<std::string>{})) << md;
    EXPECT_TRUE(contains(md, "$n = ac \\times ab = (0, 0, -4)$")) << md;
    EXPECT_TRUE(contains(md, "$\\langle n, x\\rangle = \\langle n, a\\rangle = -4$")) << md;
    EXPECT_TRUE(contains(md, "Exactly, $t = \\frac{1}{3}$.")) << md;
    EXPECT_TRUE(contains(md, "$da \\times db = ")) << md;
    EXPECT_TRUE(contains(md, "inside the triangle *abc*")) << md;
    EXPECT_FALSE(contains(md, "<n,")) << md;
    EXPECT_FALSE(contains(md, " x ab")) << md;

    const std::string parallel = markdown(s, {{0, 0, 0}, {1, 0, 0}});
    EXPECT_TRUE(contains(parallel, "Since $\\langle n, v\\rangle = 0$, the ray is parallel"))
        << parallel;
    EXPECT_EQ(words_in_math(parallel), (std::vector<std::string>{})) << parallel;
}

// Coordinates whose products leave double's range: JSON gives no coefficients or plane (null,
// with out_of_range) rather than inf and nan, and Markdown says why in place of the algebra.
TEST(ExplainDocument, ProductsBeyondDoublesRangeAreNotWrittenOut) {
    engine::Scene s;
    s.materials.push_back(engine::Material{});
    s.objects.push_back(engine::testing::sphere("far", {0, 0, 0}, 1e199, 0));
    s.objects.push_back(engine::testing::mesh_object(
        "huge", {{-1e120, -1e120, 3e200}, {4e120, -1e120, 3e200}, {-1e120, 4e120, 3e200}},
        {{0, 1, 2}}));
    const engine::Ray ray{{0, 0, -1e200}, {0, 0, 1}};
    const engine::Explanation ex = engine::explain(s, ray).value();
    const std::string json = write_explain_json(ex, ray);
    const std::regex inf_or_nan(R"(\b(inf|nan)\b)");
    EXPECT_FALSE(std::regex_search(json, inf_or_nan)) << json;
    EXPECT_TRUE(contains(json, R"("coefficients":null,"discriminant":null,"out_of_range":true)"))
        << json;
    EXPECT_TRUE(contains(json, R"("normal":null,"plane":null,"out_of_range":true,"t":4e+200)"))
        << json;
    EXPECT_FALSE(contains(json, "cross_products")) << json;
    const std::string md = write_explain_markdown(ex, ray);
    EXPECT_EQ(words_in_math(md), (std::vector<std::string>{})) << md;
    EXPECT_FALSE(std::regex_search(md, inf_or_nan)) << md;
    EXPECT_TRUE(contains(md, "leave double precision's range")) << md;
    EXPECT_TRUE(contains(md, "They find $t = 9 \\times 10^{199}$")) << md;
    EXPECT_TRUE(contains(md, "finds a hit at $t = 4 \\times 10^{200}$")) << md;
}

// Inputs that are not simple decimals get no exact form; tiny numbers are written with
// \times 10^{k}; names from the document are escaped, so a "$" in a name stays text.
TEST(ExplainMarkdown, NoExactFormForIrregularInputsAndEscapedNames) {
    engine::Scene s;
    s.materials.push_back(engine::Material{});
    engine::Object o;
    o.kind = engine::ObjectKind::sphere;
    o.name = "cost $5 *bold*";
    o.sphere = {{0.1234567891, 0, 10}, 2.0};
    s.objects.push_back(o);
    const std::string md = markdown(s, {{0, 0, 0}, {1e-5, 0, 1}});
    EXPECT_EQ(words_in_math(md), (std::vector<std::string>{})) << md;
    EXPECT_FALSE(contains(md, "exactly")) << md;
    EXPECT_TRUE(contains(md, "10^{-5}")) << md;

    // A tiny radius squared: (10^{-6})^2, not the double superscript 10^{-6}^2.
    s.objects[0].sphere = {{0, 0, 40}, 1e-6};
    const std::string tiny = markdown(s, {{0, 0, 0}, {0, 0, 1}});
    EXPECT_TRUE(contains(tiny, "= (10^{-6})^2$$")) << tiny;
    EXPECT_FALSE(contains(tiny, "}^2")) << tiny;
    EXPECT_TRUE(contains(md, "cost \\$5 \\*bold\\*")) << md;

    engine::Scene decimals;
    decimals.materials.push_back(engine::Material{});
    o.name = "sphere 1";
    o.sphere = {{0.5, 0, 4}, 1.5};
    decimals.objects.push_back(o);
    // (t−4)² + 0.25 = 2.25: t = 4 ± √2.
    const std::string exact = markdown(decimals, {{0, 0, 0}, {0, 0, 1}});
    EXPECT_TRUE(contains(exact, "$t = 4 \\pm \\sqrt{2}$")) << exact;
}

}  // namespace
}  // namespace raycastd::server
