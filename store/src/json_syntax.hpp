#pragma once
// JSON's syntax (RFC 8259) checked without building a document: what the store asks of the JSON
// objects it keeps (a fit's assessment, a measurement's settings), on every write. It accepts
// exactly what nlohmann::json::accept does (a leading byte-order mark, strings of UTF-8 with no
// overlong forms, surrogates or raw control characters, \u escapes with paired surrogates, any
// depth), which tests/fuzz/json_syntax_fuzz.cpp checks on arbitrary bytes, at a small part of
// its cost: no token is copied and no number converted.

#include <string_view>

namespace skinspec::store::detail {

// One JSON value, alone but for whitespace around it, whose first token opens an object.
bool is_json_object(std::string_view text);
// One JSON value of any kind, alone but for whitespace around it.
bool is_json(std::string_view text);

}  // namespace skinspec::store::detail
