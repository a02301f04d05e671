#pragma once
// What is wrong with a JSON file amhv reads, in amhv's words: the JSON library's own message (its
// internals, quoted input) never reaches the user.
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace amhv {

inline std::string json_problem(const nlohmann::json::exception& e) {
    if (const auto* parse = dynamic_cast<const nlohmann::json::parse_error*>(&e))
        return fmt::format("not valid JSON (at byte {})", parse->byte);
    if (dynamic_cast<const nlohmann::json::type_error*>(&e)) return "a value has the wrong type";
    if (dynamic_cast<const nlohmann::json::out_of_range*>(&e)) return "a key or an item is missing";
    return "not the JSON expected";
}

}  // namespace amhv
