// The strict JSON reader shared by shape and case files: paths and file in every error, the whole
// expectation in type errors, fixed-size arrays naming the bad component, unknown keys with the
// nearest known one, syntax errors with their line.
#include <gtest/gtest.h>

#include <string>

#include "shatter/core/json_reader.h"
#include "support/test_support.h"

namespace shatter::json_input {
namespace {

const std::string kFile = "t.json";

TEST(JsonReader, TypedReadersNameTheFieldAndExpectation) {
  const Where root{&kFile, ""};
  const Json j = Json::parse(R"({"a": "x", "v": [1, 0, 2], "p": [1, 2, 3], "n": -1})");
  auto r = read_non_negative(j["a"], root.key("a"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().file, kFile);
  EXPECT_EQ(r.error().field, "a");
  EXPECT_EQ(r.error().message, "expected a number >= 0, got a string (\"x\")");
  EXPECT_EQ(read_non_negative(j["n"], root.key("n")).error().message, "expected a number >= 0, got -1");
  EXPECT_EQ(read_positive(j["a"], root.key("a")).error().message, "expected a number > 0, got a string (\"x\")");
  EXPECT_EQ(read_number(j["a"], root.key("a")).error().message, "expected a number, got a string (\"x\")");

  auto v = read_positive_vec3(j["v"], root.key("v"));
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error().field, "v[1]");
  EXPECT_EQ(v.error().message, "expected a number > 0, got 0");
  auto ok3 = read_vec3(j["v"], root.key("v"));
  ASSERT_OK(ok3);
  EXPECT_EQ(*ok3, Vec3(1, 0, 2));
  auto p = read_vec2(j["p"], root.key("p"));
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().field, "p");
  EXPECT_EQ(p.error().message, "expected an array of 2 numbers [x, y], got an array of 3");
  EXPECT_EQ(read_vec3(j["n"], root.key("n")).error().message,
            "expected an array of 3 numbers [x, y, z], got the number -1");
  // The root itself is "(top level)".
  EXPECT_EQ(read_array(j, root).error().field, "(top level)");
}

TEST(JsonReader, UnknownKeySuggestsTheNearest) {
  const Where root{&kFile, "solver"};
  const Json j = Json::parse(R"({"tolerance": 1, "max_iteration": 5})");
  ObjectReader r(j, root);
  ASSERT_OK(r.status());
  EXPECT_NE(r.get("tolerance"), nullptr);
  EXPECT_EQ(r.get("max_iterations"), nullptr);
  auto done = r.finish();
  ASSERT_FALSE(done.ok());
  EXPECT_EQ(done.error().field, "solver.max_iteration");
  EXPECT_NE(done.error().message.find("did you mean \"max_iterations\""), std::string::npos) << done.error().message;
  const Json array = Json::parse("[1]");
  ObjectReader not_object(array, root.index(2));
  ASSERT_FALSE(not_object.status().ok());
  EXPECT_EQ(not_object.status().error().field, "solver[2]");
}

TEST(JsonReader, SyntaxErrorsNameTheLine) {
  auto r = parse_json("{\n  \"a\": 1,\n  \"b\": [,]\n}", kFile);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().file, kFile);
  EXPECT_EQ(r.error().line, 3);
  EXPECT_EQ(r.error().message.rfind("invalid JSON: ", 0), 0u) << r.error().message;
}

TEST(JsonReader, NestingIsBoundedBeforeParsing) {
  auto nested = [](int depth) {
    std::string t;
    for (int i = 0; i < depth; ++i) t += i % 2 ? "{\"a\": " : "[";
    t += "1";
    for (int i = depth - 1; i >= 0; --i) t += i % 2 ? "}" : "]";
    return t;
  };
  EXPECT_TRUE(parse_json(nested(kMaxJsonDepth), kFile).ok());
  auto r = parse_json(nested(kMaxJsonDepth + 1), kFile);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("nested deeper than 256"), std::string::npos) << r.error().to_string();
  EXPECT_EQ(r.error().file, kFile);
  // 100,000 levels: an error, not a stack overflow. Brackets inside strings do not count.
  EXPECT_FALSE(parse_json(nested(100'000), kFile).ok());
  EXPECT_TRUE(parse_json("{\"a\": \"[[[[\\\"[[[[\"}", kFile).ok());
}

TEST(JsonReader, DuplicateKeysAndHugeNumbersAreErrors) {
  auto r = parse_json(R"({"tets": 100, "tets": 200})", kFile);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("duplicate key tets"), std::string::npos) << r.error().to_string();
  EXPECT_EQ(r.error().file, kFile);
  r = parse_json(R"({"shape": {"children": [{"type": "a"}, {"type": "b", "radius": 1, "radius": 2}]}})", kFile);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("duplicate key shape.children[1].radius"), std::string::npos)
      << r.error().to_string();
  // The same key in different objects is fine.
  EXPECT_TRUE(parse_json(R"({"a": {"x": 1}, "b": {"x": 2}, "c": [{"x": 1}, {"x": 2}]})", kFile).ok());
  r = parse_json(R"({"radius": 1e400})", kFile);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().file, kFile);
  EXPECT_EQ(r.error().message, "invalid JSON: number overflow parsing '1e400'") << r.error().to_string();
}

TEST(JsonReader, StringsWithNulAreRefused) {
  const Json j = Json::parse(R"({"name": "bar\u0000x", "ok": "bar"})");
  const Where root{&kFile, ""};
  auto bad = read_string(j["name"], root.key("name"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("NUL"), std::string::npos) << bad.error().to_string();
  EXPECT_EQ(bad.error().field, "name");
  auto ok = read_string(j["ok"], root.key("ok"));
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(*ok, "bar");
}

}  // namespace
}  // namespace shatter::json_input
