// A fit's parameters as the store keeps them (store/src/codec.hpp): written without building
// JSON values first, yet read back bit for bit by the JSON reader, whatever the names and values.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <string_view>
#include <nlohmann/json.hpp>

#include "codec.hpp"
#include "db.hpp"
#include "support/fit_params_document.hpp"

namespace skinspec::store::detail {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

void expect_round_trip(const std::vector<FitParam>& params) {
  const auto text = encode_fit_params(params);
  ASSERT_TRUE(nlohmann::json::accept(text)) << text;
  const auto read = decode_fit_params(text, "the test's fit");
  ASSERT_EQ(read.size(), params.size()) << text;
  for (std::size_t i = 0; i < params.size(); ++i) {
    EXPECT_EQ(read[i].name, params[i].name) << text;
    EXPECT_EQ(std::signbit(read[i].value), std::signbit(params[i].value)) << text;
    EXPECT_EQ(read[i].value, params[i].value) << text;
    if (std::isfinite(params[i].standard_error)) {
      EXPECT_EQ(read[i].standard_error, params[i].standard_error) << text;
    } else {
      EXPECT_EQ(read[i].standard_error, kInfinity) << text;
    }
  }
}

TEST(FitParamsCodec, NamesAndValuesReadBackExactly) {
  expect_round_trip({{"surface_reflectance", 0.039467427893325635, 0.0008807661400617365},
                     {"melanin", 7.0, 0.2},
                     {"bilirubin", 0.1 + 0.2, kInfinity},
                     {"tiny", 5e-324, std::numeric_limits<double>::quiet_NaN()},
                     {"huge", -1.7976931348623157e308, 1e-300},
                     {"zero", -0.0, 0.0},
                     {"power", 1e21, 123456789012345678.0}});
}

TEST(FitParamsCodec, NamesThatNeedEscapingAreEscaped) {
  expect_round_trip({{"quote \" and backslash \\", 1, 1},
                     {"tab\tnewline\n", 2, 2},
                     {"\x01 control", 3, 3},
                     {"h\xC3\xA6moglobin", 4, 4}});
  // A name that is not UTF-8 is kept as the JSON library would keep it: its bad bytes replaced.
  const auto read = decode_fit_params(encode_fit_params({{"bad \xFF byte", 5, 5}}), "the test's fit");
  EXPECT_EQ(read.at(0).name, "bad \xEF\xBF\xBD byte");
}

TEST(FitParamsCodec, KeepsTheShapeOfTheJsonLibrary) {
  EXPECT_EQ(encode_fit_params({{"melanin", 0.5, kInfinity}, {"bilirubin", 2, 0.25}}),
            R"([{"name":"melanin","standard_error":null,"value":0.5},)"
            R"({"name":"bilirubin","standard_error":0.25,"value":2.0}])");
  const std::vector<FitParam> params = {{"melanin", 23.80607722279907, 0.643163604822781}};
  nlohmann::json library = nlohmann::json::array();
  library.push_back({{"name", "melanin"}, {"value", 23.80607722279907}, {"standard_error", 0.643163604822781}});
  EXPECT_EQ(nlohmann::json::parse(encode_fit_params(params)), library);
}

TEST(FitParamsCodec, ReadsAndRefusesWhatTheParsedDocumentWould) {
  const char* const texts[] = {
      R"([{"name":"m","value":1.5,"standard_error":0.5}])",
      R"([{"standard_error":null,"value":-2,"name":"m"},{"name":"b","value":3e2,"standard_error":7}])",
      R"([{"name":"m","value":1,"standard_error":1,"unit":"mg/ml","why":{"a":[1,{"name":2}],"b":null}}])",
      R"([{"name":"m","value":1,"standard_error":1,"name":"n","value":2}])",
      R"([{"name":"m","value":18446744073709551615,"standard_error":-9223372036854775808}])",
      R"( [ {"name" : "m" , "value" : 1 , "standard_error" : 2 } ] )",
      R"([])",
      R"({})",
      R"("m")",
      R"(1)",
      R"(null)",
      R"([1])",
      R"([[{"name":"m","value":1,"standard_error":1}]])",
      R"([{"name":"m","value":1,"standard_error":1},2])",
      R"([{"name":"m","value":1,"standard_error":1},null])",
      R"([{"name":"m","value":1}])",
      R"([{"name":"m","standard_error":1}])",
      R"([{"value":1,"standard_error":1}])",
      R"([{"name":1,"value":1,"standard_error":1}])",
      R"([{"name":null,"value":1,"standard_error":1}])",
      R"([{"name":["m"],"value":1,"standard_error":1}])",
      R"([{"name":"m","value":"1","standard_error":1}])",
      R"([{"name":"m","value":null,"standard_error":1}])",
      R"([{"name":"m","value":true,"standard_error":1}])",
      R"([{"name":"m","value":[1],"standard_error":1}])",
      R"([{"name":"m","value":{"v":1},"standard_error":1}])",
      R"([{"name":"m","value":1,"standard_error":1,"value":[2]}])",
      R"([{"name":1,"name":"m","value":1,"standard_error":1}])",
      R"([{"name":["m"],"name":"m","value":1,"standard_error":1}])",
      R"([{"name":"m","value":"1","value":1,"standard_error":1}])",
      R"([{"name":"m","value":[1],"value":1,"standard_error":1}])",
      R"([{"name":"m","value":{"v":1},"value":2,"standard_error":1}])",
      R"([{"name":"m","value":1,"standard_error":"x","standard_error":null}])",
      R"([{"name":"m","value":1,"standard_error":{},"standard_error":3}])",
      R"([{"name":"a","value":1,"standard_error":1},{"name":"b","value":2}])",
      R"([{"name":"a","value":1,"standard_error":1},{"standard_error":2}])",
      "\xEF\xBB\xBF[{\"name\":\"m\",\"value\":-0,\"standard_error\":1e-400}]",
      R"([/*c*/{"name":"m","value":1,"standard_error":1}])",
      R"([{"name":"m","value":-9223372036854775809,"standard_error":1}])",
      R"([{"name":"m","value":1,"standard_error":1,"name":{"n":"x"}}])",
      R"([{"name":"m","value":1,"standard_error":1,"standard_error":"1"}])",
      R"([{"name":"m","value":1,"standard_error":"1"}])",
      R"([{"name":"m","value":1,"standard_error":false}])",
      R"([{"name":"m","value":1,"standard_error":{}}])",
      R"([{"name":"m","value":1,"standard_error":[]}])",
      R"([{"name":"m","value":1,"standard_error":1}] x)",
      R"([{"name":"m","value":1,"standard_error":1})",
      R"([{"name":"m","value":1e999,"standard_error":1}])",
      R"([{"name":"m\u00e6","value":1,"standard_error":1}])",
      "",
  };
  for (const std::string_view text : texts) {
    const auto expected = testing::fit_params_through_a_document(text);
    std::optional<std::vector<FitParam>> read;
    try {
      read = decode_fit_params(text, "the test's fit");
    } catch (const Failure& failure) {
      EXPECT_EQ(failure.error.kind, StoreError::Kind::corrupt) << text;
      EXPECT_NE(failure.error.message.find("the test's fit: not a JSON array"), std::string::npos) << text;
    }
    ASSERT_EQ(read.has_value(), expected.has_value()) << text;
    if (!read) continue;
    ASSERT_EQ(read->size(), expected->size()) << text;
    for (std::size_t i = 0; i < read->size(); ++i) {
      EXPECT_EQ((*read)[i].name, (*expected)[i].name) << text;
      EXPECT_EQ((*read)[i].value, (*expected)[i].value) << text;
      EXPECT_EQ((*read)[i].standard_error, (*expected)[i].standard_error) << text;
    }
  }
}

}  // namespace
}  // namespace skinspec::store::detail
