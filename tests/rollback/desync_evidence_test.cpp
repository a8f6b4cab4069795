// The desync evidence file's name and content (rollback/desync_evidence.h): the one format every
// writer uses (lockroll run/live, net::SessionBuilder::desync_report_dir).
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <string>

#include "rollback/desync_evidence.h"
#include "rollback/simulation.h"

namespace lockroll::rollback {
namespace {

// Two bytes of state and nothing else: describe_state is Simulation's generic hex dump.
class Bytes final : public Simulation {
public:
    using Simulation::step;
    void step(std::span<const std::uint8_t>) override {}
    std::size_t state_size() const override { return 2; }
    void save(std::span<std::uint8_t> out) const override { out[0] = out[1] = 0; }
    std::string load(std::span<const std::uint8_t>) override { return {}; }
};

DesyncReport report() {
    DesyncReport r;
    r.peer = 3;
    r.frame = 41;
    r.detected_frame = 48;
    r.summary = "frame 41: body 7 field vel_y differs";
    r.local_state = {0xAB, 0x01};
    return r;
}

TEST(DesyncEvidence, FileNameNamesClientPeerAndFrame) {
    EXPECT_EQ(desync_evidence_file_name(1, report()), "desync-client1-peer3-frame41.txt");
    DesyncReport other = report();
    other.frame = 42;  // another frame, another file: nothing is overwritten
    EXPECT_NE(desync_evidence_file_name(1, other), desync_evidence_file_name(1, report()));
    EXPECT_NE(desync_evidence_file_name(3, report()), desync_evidence_file_name(1, report()));
}

TEST(DesyncEvidence, TextIsTheSummaryThenTheDescribedState) {
    const Bytes sim;
    const DesyncReport r = report();
    const std::string text = desync_evidence_text(r, sim);
    EXPECT_EQ(text, r.summary + "\n" + sim.describe_state(r.local_state));
    EXPECT_EQ(text.rfind(r.summary, 0), 0u);  // the first line names body and field
    EXPECT_GT(text.size(), r.summary.size() + 1);
}

TEST(DesyncEvidence, NoStateNoText) {
    const Bytes sim;
    DesyncReport r = report();
    r.local_state.clear();
    EXPECT_TRUE(desync_evidence_text(r, sim).empty());
}

}  // namespace
}  // namespace lockroll::rollback
