#pragma once
// What is wrong with a JSON file amhv reads, in amhv's words: the JSON library's own message (its
// internals, quoted input) never reaches the user.
#include <cstdint>
#include <limits>
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

// An integer of type T from a file's JSON: a JSON integer within T's range, else the library's
// type_error (nlohmann converts a float, or an integer out of range, by a cast, which is undefined
// for values the type cannot hold).
template <class T>
T json_integer(const nlohmann::json& j) {
    if (j.is_number_unsigned()) {
        const std::uint64_t v = j.get<std::uint64_t>();
        if (v <= std::uint64_t(std::numeric_limits<T>::max())) return T(v);
    } else if (j.is_number_integer()) {
        const std::int64_t v = j.get<std::int64_t>();
        if (v >= std::int64_t(std::numeric_limits<T>::min()) && (v < 0 || std::uint64_t(v) <= std::uint64_t(std::numeric_limits<T>::max())))
            return T(v);
    }
    throw nlohmann::json::type_error::create(302, "not an integer in range", &j);
}

}  // namespace amhv
