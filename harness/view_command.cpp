#include "harness/view_command.h"

#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "harness/match/atomic_file.h"
#include "harness/match/cli_error.h"
#include "harness/view_page.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;

// Above this much JSON the data goes in gzip + base64 (a 1k-body run is tens of megabytes raw).
constexpr std::size_t kCompressAbove = 1u << 20;
constexpr double kScale = 1e5;  // positions as integers of 10 µm: exact enough to show any error

struct Csv {
    fs::path path;
    std::vector<std::string> header;
    std::vector<std::vector<std::string>> rows;
    std::size_t column(const std::string& name) const {
        for (std::size_t i = 0; i < header.size(); ++i)
            if (header[i] == name) return i;
        throw UsageError(path.string() + ": missing column " + name);
    }
    double number(std::size_t row, std::size_t col) const {
        const std::string& t = rows[row][col];
        char* end = nullptr;
        const double v = std::strtod(t.c_str(), &end);
        if (t.empty() || *end != '\0' || !std::isfinite(v))
            throw UsageError(path.string() + ":" + std::to_string(row + 2) + ": column " + header[col] + ": '" + t +
                             "' is not a number");
        return v;
    }
};

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string item;
    while (std::getline(ss, item, ',')) out.push_back(item);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
}

Csv read_csv(const fs::path& path, const char* hint) {
    std::ifstream in(path);
    if (!in) throw UsageError(path.string() + ": not found" + hint);
    Csv csv;
    csv.path = path;
    std::string line;
    if (!std::getline(in, line)) throw UsageError(path.string() + ": empty file");
    csv.header = split(line);
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        csv.rows.push_back(split(line));
        if (csv.rows.back().size() != csv.header.size())
            throw UsageError(path.string() + ":" + std::to_string(csv.rows.size() + 1) + ": expected " +
                             std::to_string(csv.header.size()) + " fields");
    }
    return csv;
}

std::string gzip(const std::string& data) {
    z_stream z{};
    if (deflateInit2(&z, Z_BEST_COMPRESSION, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY) != Z_OK)
        throw std::runtime_error("zlib: deflateInit2 failed");
    std::string out(deflateBound(&z, data.size()), '\0');
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
    z.avail_in = static_cast<uInt>(data.size());
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(out.size());
    const int rc = deflate(&z, Z_FINISH);
    deflateEnd(&z);
    if (rc != Z_STREAM_END) throw std::runtime_error("zlib: deflate failed");
    out.resize(z.total_out);
    return out;
}

std::string base64(const std::string& in) {
    static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((in.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < in.size(); i += 3) {
        const std::uint32_t n = static_cast<std::uint32_t>(static_cast<unsigned char>(in[i])) << 16 |
                                (i + 1 < in.size() ? static_cast<std::uint32_t>(static_cast<unsigned char>(in[i + 1])) << 8 : 0) |
                                (i + 2 < in.size() ? static_cast<unsigned char>(in[i + 2]) : 0);
        out += kAlphabet[n >> 18 & 63];
        out += kAlphabet[n >> 12 & 63];
        out += i + 1 < in.size() ? kAlphabet[n >> 6 & 63] : '=';
        out += i + 2 < in.size() ? kAlphabet[n & 63] : '=';
    }
    return out;
}

// JSON of the data the page reads (see view_page.h).
std::string view_data(const fs::path& dir) {
    const char* hint = " (run with --positions or --view)";
    const Csv frames = read_csv(dir / "frames.csv", ""), bodies = read_csv(dir / "bodies.csv", hint),
              positions = read_csv(dir / "positions.csv", hint);
    const fs::path events_path = dir / "events.csv";
    const Csv events = fs::exists(events_path) ? read_csv(events_path, "") : Csv{};

    std::string j = "{";
    // Frames: numbers and time as numbers; mean/max copied verbatim from frames.csv.
    const std::size_t f_frame = frames.column("frame"), f_time = frames.column("time_s"),
                      f_mean = frames.column("mean_error"), f_max = frames.column("max_error"),
                      f_rb = frames.column("rollbacks");
    std::vector<long> frame_numbers;
    std::string fr = "[", tm = "[", mn = "[", mx = "[", rb = "[";
    for (std::size_t i = 0; i < frames.rows.size(); ++i) {
        const char* sep = i ? "," : "";
        frame_numbers.push_back(std::lround(frames.number(i, f_frame)));
        for (std::size_t c : {f_time, f_mean, f_max, f_rb}) (void)frames.number(i, c);  // validates
        fr += sep + frames.rows[i][f_frame];
        tm += sep + frames.rows[i][f_time];
        mn += sep + frames.rows[i][f_mean];
        mx += sep + frames.rows[i][f_max];
        rb += sep + frames.rows[i][f_rb];
    }
    if (frame_numbers.empty()) throw UsageError((dir / "frames.csv").string() + ": no frames");
    j += "\"frames\":" + fr + "],\"time\":" + tm + "],\"mean\":" + mn + "],\"max\":" + mx + "],\"rollbacks\":" + rb + "],";

    // Bodies.
    const std::size_t b_index = bodies.column("index"), b_player = bodies.column("player"), b_dyn = bodies.column("dynamic"),
                      b_shape = bodies.column("shape"), b_x = bodies.column("x"), b_z = bodies.column("z"),
                      b_r = bodies.column("radius"), b_hx = bodies.column("hx"), b_hz = bodies.column("hz");
    std::vector<std::string> dyn;
    std::string statics = "[";
    for (std::size_t i = 0; i < bodies.rows.size(); ++i) {
        const auto& row = bodies.rows[i];
        for (std::size_t c : {b_index, b_player, b_dyn, b_x, b_z, b_r, b_hx, b_hz}) (void)bodies.number(i, c);
        const std::string shape = "\"" + std::string(row[b_shape] == "box" ? "box" : "round") + "\"";
        if (row[b_dyn] == "1") {
            const auto index = static_cast<std::size_t>(bodies.number(i, b_index));
            if (index >= dyn.size()) dyn.resize(index + 1);
            dyn[index] = "[" + row[b_player] + "," + shape + "," + row[b_r] + "," + row[b_hx] + "," + row[b_hz] + "]";
        } else {
            statics += (statics.size() > 1 ? "," : "") + std::string("[") + shape + "," + row[b_x] + "," + row[b_z] + "," +
                       row[b_r] + "," + row[b_hx] + "," + row[b_hz] + "]";
        }
    }
    std::string dynamic = "[";
    for (std::size_t i = 0; i < dyn.size(); ++i) {
        if (dyn[i].empty()) throw UsageError((dir / "bodies.csv").string() + ": no row for body index " + std::to_string(i));
        dynamic += (i ? "," : "") + dyn[i];
    }
    j += "\"bodies\":" + dynamic + "],\"statics\":" + statics + "],\"scale\":" + std::to_string(static_cast<long>(kScale)) + ",";

    // Positions: [client][frame index][body][x, z].
    const std::size_t p_frame = positions.column("frame"), p_client = positions.column("client"),
                      p_body = positions.column("body_index"), p_x = positions.column("x"), p_z = positions.column("z");
    const std::size_t nb = dyn.size(), nf = frame_numbers.size();
    const long first = frame_numbers.front();
    int clients = 0;
    for (std::size_t i = 0; i < positions.rows.size(); ++i)
        clients = std::max(clients, static_cast<int>(positions.number(i, p_client)) + 1);
    std::vector<std::vector<long long>> pos(static_cast<std::size_t>(clients), std::vector<long long>(nf * nb * 2, 0));
    for (std::size_t i = 0; i < positions.rows.size(); ++i) {
        const long f = std::lround(positions.number(i, p_frame)) - first;
        const auto c = static_cast<std::size_t>(positions.number(i, p_client));
        const auto b = static_cast<std::size_t>(positions.number(i, p_body));
        if (f < 0 || static_cast<std::size_t>(f) >= nf || b >= nb)
            throw UsageError((dir / "positions.csv").string() + ":" + std::to_string(i + 2) + ": frame or body out of range");
        const std::size_t at = (static_cast<std::size_t>(f) * nb + b) * 2;
        pos[c][at] = std::llround(positions.number(i, p_x) * kScale);
        pos[c][at + 1] = std::llround(positions.number(i, p_z) * kScale);
    }
    j += "\"clients\":" + std::to_string(clients) + ",\"pos\":[";
    for (int c = 0; c < clients; ++c) {
        j += c ? ",[" : "[";
        const auto& v = pos[static_cast<std::size_t>(c)];
        for (std::size_t k = 0; k < v.size(); ++k) {
            if (k) j += ',';
            j += std::to_string(v[k]);
        }
        j += "]";
    }
    j += "],\"corrections\":[";
    if (!events.rows.empty()) {
        const std::size_t e_client = events.column("client"), e_frame = events.column("frame"),
                          e_kind = events.column("kind"), e_value = events.column("value");
        bool any = false;
        for (const auto& row : events.rows)
            if (row[e_kind] == "correction") {
                j += (any ? ",[" : "[") + row[e_client] + "," + row[e_frame] + "," + row[e_value] + "]";
                any = true;
            }
    }
    j += "]}";
    return j;
}
}  // namespace

fs::path write_view(const fs::path& dir) {
    fs::path data_dir = dir;
    if (!fs::exists(dir / "positions.csv") && fs::exists(dir / "rollback" / "positions.csv")) data_dir = dir / "rollback";
    const std::string data = view_data(data_dir);
    std::string element;
    if (data.size() > kCompressAbove)
        element = "<script id=\"lockroll-data\" type=\"application/octet-stream\" data-encoding=\"gzip+base64\">" +
                  base64(gzip(data)) + "</script>";
    else
        element = "<script id=\"lockroll-data\" type=\"application/json\">" + data + "</script>";
    std::string page = kViewPage;
    page.replace(page.find("@DATA@"), 6, element);
    const fs::path out = dir / "view.html";
    write_file_atomic(out, page);
    return out;
}

void add_view_command(CLI::App& app) {
    auto dir = std::make_shared<std::string>();
    CLI::App* cmd = app.add_subcommand(
        "view", "Write DIR/view.html: two clients' views side by side, frame by frame, with the error plot");
    cmd->add_option("DIR", *dir, "A run directory made with --positions (or --view), or a compare directory")->required();
    cmd->callback([dir] {
        if (!fs::is_directory(*dir)) throw UsageError(*dir + ": not a directory");
        std::printf("written %s\n", write_view(*dir).string().c_str());
    });
}

}  // namespace lockroll::harness
