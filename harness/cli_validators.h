// CLI11 validators the subcommands share.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

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

// `--slot 0,1` (CLI11 splits at commas): the slots one process plays, as a bit mask. Each in
// 0..players-1 and named once, else std::invalid_argument naming the flag's text and the slot
// (the commands turn it into their usage error: exit 2 before any work).
inline std::string slot_text(const std::vector<int>& slots) {  // as given: "0,1"
    std::string text;
    for (int s : slots) text += (text.empty() ? "" : ",") + std::to_string(s);
    return text;
}
inline std::uint16_t slot_mask(const std::vector<int>& slots, int players, const std::string& flag) {
    const std::string text = slot_text(slots);
    if (slots.empty()) throw std::invalid_argument(flag + ": names no slot");
    std::uint16_t mask = 0;
    for (int s : slots) {
        if (s < 0 || s >= players || s >= 16)
            throw std::invalid_argument(flag + " " + text + ": slot " + std::to_string(s) + " is out of range 0.." + std::to_string(players - 1));
        if (mask & (1u << s)) throw std::invalid_argument(flag + " " + text + ": slot " + std::to_string(s) + " is named twice");
        mask = static_cast<std::uint16_t>(mask | (1u << s));
    }
    return mask;
}

}  // namespace lockroll::harness
