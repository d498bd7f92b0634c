// JSON text with the project's input errors: syntax errors and numbers
// beyond a double named by file and line (a number overflow was found by
// the config fuzzer escaping as nlohmann's own exception).
#include "ttp/geometry/json_text.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_dir.h"
#include "ttp/geometry/config.h"
#include "ttp/geometry/error.h"

namespace ttp {
namespace {

InputError ErrorOf(const std::string& text) {
  try {
    ParseJsonText(text, "doc.json");
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted: " << text;
  return InputError("", 0, "", "");
}

TEST(JsonText, ParsesJson) {
  const nlohmann::json j = ParseJsonText("{\"a\": [1, 2.5e3]}", "doc.json");
  EXPECT_DOUBLE_EQ(j["a"][1].get<double>(), 2500.0);
}

TEST(JsonText, ASyntaxErrorNamesItsLine) {
  const InputError e = ErrorOf("{\n  \"a\": 1,\n  \"b\": ]\n}");
  EXPECT_EQ(e.line(), 3);
  EXPECT_NE(std::string(e.what()).find("doc.json"), std::string::npos);
  EXPECT_NE(std::string(e.what()).find("not valid JSON"), std::string::npos);
}

TEST(JsonText, ANumberBeyondADoubleNamesItsLine) {
  const InputError e = ErrorOf("{\n  \"a\": 1,\n\n  \"b\": 1e400\n}");
  EXPECT_EQ(e.line(), 4);
  EXPECT_NE(std::string(e.what()).find("range of a double"), std::string::npos);
}

// JSON leaves a repeated key to the reader (RFC 8259 section 4); nlohmann
// would keep the last one. Two values for one name in a measurement are a
// broken file: refused naming the key and the line of its repeat, in any
// object; the same key in two different objects is fine.
TEST(JsonText, AKeyRepeatedInOneObjectIsRefused) {
  EXPECT_NO_THROW(ParseJsonText(
      "{\"a\": {\"u\": 1}, \"b\": {\"u\": 2}, \"c\": [{\"u\": 3}, {\"u\": 4}]}",
      "doc.json"));
  InputError e = ErrorOf("{\n  \"a\": 1,\n  \"b\": 2,\n  \"a\": 3\n}");
  EXPECT_EQ(e.line(), 4);
  EXPECT_EQ(e.field(), "a");
  EXPECT_NE(std::string(e.what()).find("twice"), std::string::npos);
  // Nested, after the same key in a sibling object.
  e = ErrorOf(
      "{\"f\": {\"u\": 1},\n \"g\": {\"u\": 1,\n \"v\": 2,\n \"u\": 5}}");
  EXPECT_EQ(e.line(), 4);
  EXPECT_EQ(e.field(), "u");
}

// The fuzzer's input: a config whose number overflows a double ended the
// process with an uncaught nlohmann exception instead of an input error.
TEST(JsonText, AConfigWithAnOverflowingNumberIsAnInputError) {
  const std::filesystem::path path =
      test::TestDir("json_text") / "overflow.json";
  std::ofstream(path)
      << "{\n  \"machine\": {\n    \"c_max_rpm\": 1200.0,\n"
         "    \"h_mm\": 8888888888888888888888888888888888E88888.88888\n"
         "  }\n}\n";
  try {
    LoadConfig(path);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 4);
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos);
  }
}

// Text from input files need not be UTF-8 (a Latin-1 comment): written
// with U+FFFD in place of the bad bytes, and the result reads back.
TEST(JsonText, BytesThatAreNotUtf8AreReplaced) {
  nlohmann::json doc;
  doc["text"] = std::string("Fr\xe9sage");
  doc["n"] = 1.5;
  const std::string text = JsonText(doc, 2);
  const nlohmann::json back = ParseJsonText(text, "written");
  EXPECT_EQ(back["text"].get<std::string>(), "Fr\xef\xbf\xbdsage");
  EXPECT_EQ(back["n"].get<double>(), 1.5);
  EXPECT_EQ(JsonText(back), back.dump());  // valid UTF-8 as nlohmann writes it
}

}  // namespace
}  // namespace ttp
