// SPDX-License-Identifier: MIT
#include "JsonText.h"

namespace csgv {

std::string jsonTooDeep(const char* text, size_t size) {
    unsigned depth = 0;
    bool inString = false;
    for (size_t i = 0; i < size; ++i) {
        const char c = text[i];
        if (inString) {
            if (c == '\\') ++i; // the escaped character cannot end the string
            else if (c == '"') inString = false;
        } else if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonDepth)
                return "nests arrays or objects more than " + std::to_string(kMaxJsonDepth) + " levels deep";
        } else if ((c == ']' || c == '}') && depth > 0) {
            --depth;
        }
    }
    return std::string();
}

std::string jsonText(const nlohmann::json& v) {
    if (v.is_array()) return "an array of " + std::to_string(v.size()) + (v.size() == 1 ? " element" : " elements");
    if (v.is_object()) return "an object";
    std::string s = v.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
    return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

} // namespace csgv
