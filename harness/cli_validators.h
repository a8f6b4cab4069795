// CLI11 validators the subcommands share.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

namespace lockroll::harness {

// For unsigned options: CLI11 converts "-1" to an unsigned 2^64 - 1 without complaint, and its
// NonNegativeNumber message prints DBL_MAX in full. Checked on the text, before conversion.
inline const CLI::Validator kNonNegativeInteger(
    [](std::string& text) -> std::string {
        const auto first = text.find_first_not_of(" \t");
        if (first != std::string::npos && text[first] == '-') return "must be a non-negative integer, got " + text;
        return {};
    },
    "UINT");

}  // namespace lockroll::harness
