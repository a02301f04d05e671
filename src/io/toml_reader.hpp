#pragma once
// Reading TOML input files with errors that name the file, the line and the key: one table at a
// time, remembering which keys were read so that unknown keys are refused.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "src/core/error.hpp"

namespace amhv {

// Reads one TOML table, remembering which keys it consumed so unknown keys can be reported.
class TableReader {
public:
    TableReader(const toml::table& table, std::string path, const std::filesystem::path& file) : table_(table), path_(std::move(path)), file_(file) {}

    std::string key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
    int line(const toml::node* node) const { return node ? int(node->source().begin.line) : int(table_.source().begin.line); }
    std::string where(const std::string& key, const toml::node* node) const {
        return fmt::format("{}:{}: {}", file_.string(), line(node), key_path(key));
    }
    template <typename... Args>
    [[noreturn]] void error(const std::string& key, const toml::node* node, fmt::format_string<Args...> format, Args&&... args) const {
        fail(where(key, node), format, std::forward<Args>(args)...);
    }

    const toml::node* get(const std::string& key) {
        used_.insert(key);
        return table_.get(key);
    }
    bool has(const std::string& key) const { return table_.contains(key); }

    std::optional<double> number(const std::string& key, double min, double max, bool min_inclusive = true) {
        const toml::node* node = get(key);
        if (!node) return std::nullopt;
        if (!node->is_number()) error(key, node, "must be a number, not {}", type_name(*node));
        double v = node->value<double>().value();
        if (!std::isfinite(v) || v < min || v > max || (!min_inclusive && v == min))
            error(key, node, "{} is out of range {}{}, {}]", v, min_inclusive ? "[" : "(", min, max);
        return v;
    }
    std::optional<int> integer(const std::string& key, int min, int max) {
        const toml::node* node = get(key);
        if (!node) return std::nullopt;
        if (!node->is_integer()) error(key, node, "must be an integer, not {}", type_name(*node));
        std::int64_t v = node->value<std::int64_t>().value();
        if (v < min || v > max) error(key, node, "{} is out of range [{}, {}]", v, min, max);
        return int(v);
    }
    std::optional<std::string> string(const std::string& key) {
        const toml::node* node = get(key);
        if (!node) return std::nullopt;
        if (!node->is_string()) error(key, node, "must be a string, not {}", type_name(*node));
        return node->value<std::string>().value();
    }
    std::optional<bool> boolean(const std::string& key) {
        const toml::node* node = get(key);
        if (!node) return std::nullopt;
        if (!node->is_boolean()) error(key, node, "must be true or false, not {}", type_name(*node));
        return node->value<bool>().value();
    }
    template <std::size_t N>
    std::optional<std::array<double, N>> numbers(const std::string& key) {
        const toml::node* node = get(key);
        if (!node) return std::nullopt;
        const toml::array* array = node->as_array();
        if (!array || array->size() != N) error(key, node, "must be an array of {} numbers", N);
        std::array<double, N> out{};
        for (std::size_t i = 0; i < N; ++i) {
            const toml::node& item = *array->get(i);
            if (!item.is_number() || !std::isfinite(item.value<double>().value())) error(key, node, "must be an array of {} numbers", N);
            out[i] = item.value<double>().value();
        }
        return out;
    }
    std::optional<std::array<int, 2>> frame_range(const std::string& key) {
        const toml::node* node = get(key);
        if (!node) return std::nullopt;
        const toml::array* array = node->as_array();
        if (!array || array->size() != 2 || !array->get(0)->is_integer() || !array->get(1)->is_integer())
            error(key, node, "must be [first, last], two frame numbers");
        const std::int64_t first = array->get(0)->value<std::int64_t>().value(), last = array->get(1)->value<std::int64_t>().value();
        constexpr std::int64_t kMaxFrame = 10'000'000;
        if (first < 0 || last < 0 || first > kMaxFrame || last > kMaxFrame) error(key, node, "frame numbers must lie in 0..{}", kMaxFrame);
        std::array<int, 2> out{int(first), int(last)};
        if (out[0] > out[1]) error(key, node, "first frame {} is after last frame {}", out[0], out[1]);
        return out;
    }
    std::vector<std::string> strings(const std::string& key) {
        const toml::node* node = get(key);
        const toml::array* array = node ? node->as_array() : nullptr;
        if (!array || array->empty()) error(key, node, "must be a non-empty array of strings");
        std::vector<std::string> out;
        for (const toml::node& item : *array) {
            if (!item.is_string()) error(key, node, "must be an array of strings");
            out.push_back(item.value<std::string>().value());
        }
        return out;
    }
    TableReader table(const std::string& key, bool required = false) {
        const toml::node* node = get(key);
        if (!node) {
            if (required) error(key, nullptr, "is missing");
            static const toml::table empty;
            return TableReader(empty, key_path(key), file_);
        }
        if (!node->is_table()) error(key, node, "must be a table, not {}", type_name(*node));
        return TableReader(*node->as_table(), key_path(key), file_);
    }
    // Every key of the table must have been read.
    void finish() const {
        for (const auto& [key, node] : table_)
            if (!used_.count(std::string(key.str())))
                fail(fmt::format("{}:{}: {}", file_.string(), node.source().begin.line, key_path(std::string(key.str()))), "unknown key");
    }
    const std::filesystem::path& file() const { return file_; }
    // The table's keys in the order the file gives them (toml++ keeps them sorted).
    std::vector<std::string> keys_in_file_order() const {
        std::vector<std::pair<std::pair<int, int>, std::string>> keyed;
        for (const auto& [key, node] : table_)
            keyed.push_back({{int(node.source().begin.line), int(node.source().begin.column)}, std::string(key.str())});
        std::sort(keyed.begin(), keyed.end());
        std::vector<std::string> out;
        for (auto& k : keyed) out.push_back(std::move(k.second));
        return out;
    }

private:
    static std::string type_name(const toml::node& node) {
        switch (node.type()) {
            case toml::node_type::string: return "a string";
            case toml::node_type::integer: return "an integer";
            case toml::node_type::floating_point: return "a number";
            case toml::node_type::boolean: return "a boolean";
            case toml::node_type::array: return "an array";
            case toml::node_type::table: return "a table";
            default: return "a date or time";
        }
    }
    const toml::table& table_;
    std::string path_;
    std::filesystem::path file_;
    std::set<std::string> used_;
};

}  // namespace amhv
