#include "harness/partition_flag.h"

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string_view>

#include "harness/match/cli_error.h"

namespace lockroll::harness {

namespace {

constexpr char kShape[] = "expected SETS@FROM-UNTIL, e.g. 0,1/2,3@200-800";

std::vector<std::string_view> split(std::string_view text, char sep) {
    std::vector<std::string_view> parts;
    for (;;) {
        const auto at = text.find(sep);
        parts.push_back(text.substr(0, at));
        if (at == std::string_view::npos) return parts;
        text.remove_prefix(at + 1);
    }
}

// Digits only (no sign, no spaces), at most `max`.
std::optional<std::uint64_t> number(std::string_view text, std::uint64_t max) {
    if (text.empty() || text.size() > 19) return std::nullopt;
    std::uint64_t v = 0;
    for (const char ch : text) {
        if (ch < '0' || ch > '9') return std::nullopt;
        v = v * 10 + static_cast<std::uint64_t>(ch - '0');
    }
    if (v > max) return std::nullopt;
    return v;
}

transport::Micros frame_time(std::uint64_t frame, int tick_rate) {
    return frame * 1'000'000u / static_cast<std::uint64_t>(tick_rate);
}

// "--partition '<value>': [cut k '<text>': ]<part>: <problem>".
[[noreturn]] void fail_at(const std::string& where, const std::string& part, const std::string& problem) {
    throw UsageError(where + part + ": " + problem);
}

// One SETS@FROM-UNTIL; `where` names the flag value (and the cut) for messages.
transport::PartitionCut parse_cut(std::string_view text, int players, int tick_rate, const std::string& where) {
    const auto at = text.find('@');
    if (at == std::string_view::npos || text.find('@', at + 1) != std::string_view::npos)
        fail_at(where, "syntax", kShape);
    const std::string_view sets_text = text.substr(0, at), frames_text = text.substr(at + 1);

    const auto dash = frames_text.find('-');
    const std::string frames_part = "frames '" + std::string(frames_text) + "'";
    if (dash == std::string_view::npos) fail_at(where, frames_part, "expected FROM-UNTIL, two frame numbers");
    const auto from = number(frames_text.substr(0, dash), UINT32_MAX);
    const auto until = number(frames_text.substr(dash + 1), UINT32_MAX);
    if (!from || !until) fail_at(where, frames_part, "expected FROM-UNTIL, two frame numbers 0..4294967295");
    if (*from >= *until) fail_at(where, frames_part, "FROM must be below UNTIL (the cut heals at UNTIL)");

    transport::PartitionCut cut;
    const auto sets = split(sets_text, '/');
    if (sets.size() < 2)
        fail_at(where, "sets '" + std::string(sets_text) + "'", "expected two or more slot sets separated by '/'");
    for (const std::string_view set_text : sets) {
        std::vector<transport::PeerId>& set = cut.sets.emplace_back();
        for (const std::string_view slot_text : split(set_text, ',')) {
            const auto slot = number(slot_text, UINT32_MAX);
            if (!slot)
                fail_at(where, "set '" + std::string(set_text) + "'", "expected slot numbers separated by ','");
            if (*slot >= static_cast<std::uint64_t>(players))
                fail_at(where, "slot " + std::to_string(*slot),
                     "not in 0.." + std::to_string(players - 1) + " (--players " + std::to_string(players) + ")");
            const auto slot_id = static_cast<transport::PeerId>(*slot);
            if (cut.side_of(slot_id) >= 0 || std::find(set.begin(), set.end(), slot_id) != set.end())
                fail_at(where, "slot " + std::to_string(*slot), "named twice (the sets must not overlap)");
            set.push_back(slot_id);
        }
    }
    cut.from_us = frame_time(*from, tick_rate);
    cut.until_us = frame_time(*until, tick_rate);
    // Two frames a tick apart can only map to the same microsecond above 1,000,000 ticks per
    // second, which validate(RunConfig) refuses; checked anyway, since the schedule insists.
    if (cut.from_us >= cut.until_us) fail_at(where, frames_part, "FROM and UNTIL are the same microsecond at this tick rate");
    return cut;
}

}  // namespace

transport::PartitionSchedule parse_partitions(const std::vector<std::string>& values, int players, int tick_rate) {
    transport::PartitionSchedule schedule;
    for (const std::string& value : values) {
        const auto cuts = split(value, ';');
        for (std::size_t k = 0; k < cuts.size(); ++k) {
            // With several cuts in one value, say which one before the part.
            const std::string where =
                "--partition '" + value + "': " +
                (cuts.size() > 1 ? "cut " + std::to_string(k + 1) + " '" + std::string(cuts[k]) + "': " : "");
            if (tick_rate < 1) fail_at(where, "--tick-rate " + std::to_string(tick_rate), "must be at least 1");
            schedule.add(parse_cut(cuts[k], players, tick_rate, where));
        }
    }
    return schedule;
}

}  // namespace lockroll::harness
