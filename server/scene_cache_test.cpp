#include "server/scene_cache.h"

#include <gtest/gtest.h>

#include "server/schema/scene_doc.h"

namespace raycastd::server {
namespace {

std::shared_ptr<const engine::QueryEngine> build(const Json& doc, int& builds) {
    ++builds;
    return *engine::QueryEngine::build(
        std::make_shared<engine::Scene>(parse_scene_doc(doc, "", {})));
}

TEST(SceneCache, BuildsEachDocumentOnce) {
    SceneCache cache(2);
    int builds = 0;
    const Json a = Json::parse(R"({"objects":[{"type":"sphere","center":[0,0,1],"radius":2}]})");
    const Json a2 =
        Json::parse(R"({"objects":[{"radius":2.0,"center":[0,0,1.0],"type":"sphere"}]})");
    const Json b = Json::parse(R"({"objects":[{"type":"sphere","center":[0,0,2],"radius":2}]})");
    const Json c = Json::parse(R"({"objects":[{"type":"sphere","center":[0,0,3],"radius":2}]})");
    auto e1 = cache.get_or_build(a, [&] { return build(a, builds); });
    auto e2 = cache.get_or_build(a2, [&] { return build(a2, builds); });
    EXPECT_EQ(e1, e2);
    EXPECT_EQ(builds, 1);
    EXPECT_EQ(cache.hits(), 1u);
    cache.get_or_build(b, [&] { return build(b, builds); });
    cache.get_or_build(c, [&] { return build(c, builds); });  // evicts a (least recently used)
    EXPECT_EQ(builds, 3);
    cache.get_or_build(a, [&] { return build(a, builds); });
    EXPECT_EQ(builds, 4);
}

TEST(SceneCache, DocumentsNamingFilesAreNotCached) {
    EXPECT_EQ(SceneCache::cache_key(Json::parse(R"({"objects":[{"type":"mesh","uri":"a.obj"}]})")),
              "");
    EXPECT_NE(SceneCache::cache_key(Json::parse(R"({"objects":[]})")), "");
}

}  // namespace
}  // namespace raycastd::server
