#pragma once
// JSON's syntax (RFC 8259) checked without building a document: what the store asks of the JSON
// objects it keeps (a fit's assessment, a measurement's settings), on every write. It accepts
// exactly what nlohmann::json::accept does (a leading byte-order mark, strings of UTF-8 with no
// overlong forms, surrogates or raw control characters, \u escapes with paired surrogates, any
// depth, numbers refused only where they overflow a double), which tests/json_syntax_test.cpp and
// tests/fuzz/json_syntax_fuzz.cpp check, at a small part of its cost: no token is copied, and a
// number is converted only when its decimal exponent comes near a double's limit. (One number of
// hundreds of millions of digits may be judged differently: the conversions' exponent limits
// differ there.)

#include <string_view>

namespace skinspec::store::detail {

// One JSON value, alone but for whitespace around it, whose first token opens an object.
bool is_json_object(std::string_view text);
// One JSON value of any kind, alone but for whitespace around it.
bool is_json(std::string_view text);

}  // namespace skinspec::store::detail
