// The seed paper's scene as a playable program: a closed room, two player boxes and 50 balls,
// seen from above (like the paper's Figure 7), two players over ENet.
//
//   room SLOT MY_PORT PEER_PORT [--frames N] [--delay D] [--window W] [--fps F] [--bot]
//        [--font FILE] [--screenshot FILE --shot-frame F]
//
// The game owns its loop: it draws at its own rate (--fps, default 144; the match ticks at 60 Hz)
// and calls NetSession::update() once per drawn frame. Between ticks it draws the moving bodies
// blended between the last two ticks' positions by the update's interpolation fraction, so a
// 144 Hz window moves smoothly on a 60 Hz simulation.
//
// Keys: arrows or WASD move, space lifts, L toggles this client between rollback (runs ahead on
// predictions, up to --window frames) and lockstep (prediction window 0: a frame runs once its
// inputs are confirmed; set_prediction_window), Esc quits.
// The overlay says in words, each over a bar: "ping 62 ms", "input delay 2", "rollback 3 frames"
// (the newest rollback's depth), "frames behind 0" (how far the peer's frame is estimated
// behind this one's: NetworkStats::frames_behind), and the mode. Its text
// is SDL2_ttf with DejaVu Sans (Debian fonts-dejavu-core, found at its Debian path, or --font
// FILE); without that font the overlay says so once on stderr and keeps its bars.
// --bot plays by itself (tests); --screenshot saves the window as BMP once frame F is shown and
// prints, for that frame, one "overlay X Y W H WORDS" line per text it drew (the rectangle it
// drew it in), so a test can check the screenshot for the words' pixels.
// Prints the confirmed checksum of the last frame, which both windows must agree on.
#include <SDL.h>
#include <SDL_ttf.h>

#include <lockroll/net/session_builder.h>
#include <lockroll/rollback/world_simulation.h>
#include <lockroll/sim/scene.h>
#include <lockroll/sim/world.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cerrno>
#include <cstring>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace {

using lockroll::sim::Fixed;
using lockroll::sim::Vec3;

Fixed q(std::int64_t num, std::int64_t den = 1) { return Fixed::from_raw(num * Fixed::kOne / den); }

// The paper's scene (harness/scenes/paper.json), built in integers.
lockroll::sim::SceneDesc paper_scene() {
    lockroll::sim::SceneDesc s;
    s.name = "paper";
    lockroll::sim::add_room(s, {q(-6), q(0), q(-6)}, {q(6), q(5), q(6)}, q(1));
    for (int p = 0; p < 2; ++p) {
        lockroll::sim::BodyDesc b;
        b.shape = lockroll::sim::Shape::Box;
        b.position = {q(p == 0 ? -3 : 3), q(9, 10), q(0)};
        b.half_extents = {q(4, 10), q(9, 10), q(4, 10)};
        b.mass = q(5);
        b.player = p;
        s.bodies.push_back(b);
    }
    lockroll::sim::SpawnerDesc sp;
    sp.count = 50;
    sp.radius = q(1, 4);
    sp.mass = q(1);
    sp.region_min = {q(-11, 2), q(1, 2), q(-11, 2)};
    sp.region_max = {q(11, 2), q(9, 2), q(11, 2)};
    sp.max_speed = q(5);
    sp.seed = 2024;
    lockroll::sim::expand_spawner(s, sp);
    return s;
}

constexpr int kScale = 50, kTop = 70, kSize = 14 * kScale;  // 14 m of room and walls, 50 px/m
int px(Fixed x) { return kSize / 2 + static_cast<int>((x.raw * kScale) >> 32); }
int py(Fixed z) { return kTop + kSize / 2 - static_cast<int>((z.raw * kScale) >> 32); }

// The overlay's words: SDL2_ttf, one texture per label, rendered again only when its words change
// (they change a few times a second; the window draws up to --fps times).
class Label {
public:
    Label() = default;
    Label(const Label&) = delete;
    Label& operator=(const Label&) = delete;
    ~Label() { release(); }
    // Draws `words` with its top left at (x, y); with no font it draws nothing. Returns the
    // rectangle drawn (empty when nothing was).
    SDL_Rect draw(SDL_Renderer* r, TTF_Font* font, int x, int y, const std::string& words, SDL_Color colour) {
        if (!font) return {x, y, 0, 0};
        if (!texture_ || words != words_) {
            release();
            words_ = words;
            if (SDL_Surface* text = TTF_RenderUTF8_Blended(font, words.c_str(), colour)) {
                texture_ = SDL_CreateTextureFromSurface(r, text);
                w_ = text->w;
                h_ = text->h;
                SDL_FreeSurface(text);
            }
            if (!texture_) return {x, y, 0, 0};
        }
        SDL_Rect where{x, y, w_, h_};
        SDL_RenderCopy(r, texture_, nullptr, &where);
        return where;
    }

private:
    void release() {
        if (texture_) SDL_DestroyTexture(texture_);
        texture_ = nullptr;
    }
    std::string words_;
    SDL_Texture* texture_ = nullptr;
    int w_ = 0, h_ = 0;
};

// What the overlay shows, in the words a player reads.
struct OverlayValues {
    long ping_ms = 0, input_delay = 0, rollback_frames = 0, frames_behind = 0, window = 1;
    bool lockstep = false;
};

std::string plural(long n, const char* one, const char* many) { return std::to_string(n) + (n == 1 ? one : many); }

// Four gauges (words over a bar of value out of full) and the mode line, in the band above the
// room. Remembers what it drew last, for --screenshot's report.
class Overlay {
public:
    explicit Overlay(TTF_Font* font) : font_(font) {}
    void draw(SDL_Renderer* r, const OverlayValues& v) {
        drawn_.clear();
        gauge(r, 0, "ping " + std::to_string(v.ping_ms) + " ms", v.ping_ms, 200);
        gauge(r, 1, "input delay " + std::to_string(v.input_delay), v.input_delay, 10);
        gauge(r, 2, "rollback " + plural(v.rollback_frames, " frame", " frames"), v.rollback_frames, std::max(v.window, 1L));
        gauge(r, 3, "frames behind " + std::to_string(v.frames_behind), v.frames_behind, 10);
        const std::string mode = v.lockstep ? "lockstep: frames run on confirmed inputs only (L: rollback)"
                                            : "rollback: runs ahead on predicted inputs (L: lockstep)";
        record(labels_[4].draw(r, font_, kLeft, 48, mode, {255, 255, 255, 255}), mode);
    }
    // One "overlay X Y W H WORDS" line per text of the last draw().
    void report(std::FILE* out) const {
        for (const auto& [where, words] : drawn_)
            std::fprintf(out, "overlay %d %d %d %d %s\n", where.x, where.y, where.w, where.h, words.c_str());
    }

private:
    static constexpr int kLeft = 10, kColumn = 172, kBar = 150;
    void gauge(SDL_Renderer* r, int column, const std::string& words, long value, long full) {
        const int x = kLeft + column * kColumn;
        record(labels_[column].draw(r, font_, x, 6, words, {230, 230, 230, 255}), words);
        SDL_SetRenderDrawColor(r, 60, 60, 60, 255);
        SDL_Rect back{x, 30, kBar, 10};
        SDL_RenderFillRect(r, &back);
        SDL_SetRenderDrawColor(r, 80, 200, 90, 255);
        SDL_Rect bar{x, 30, static_cast<int>(kBar * std::clamp(value, 0L, full) / full), 10};
        if (bar.w > 0) SDL_RenderFillRect(r, &bar);  // SDL draws a zero-wide rectangle as a line
    }
    void record(SDL_Rect where, const std::string& words) {
        if (where.w > 0) drawn_.emplace_back(where, words);
    }
    TTF_Font* font_;
    Label labels_[5];
    std::vector<std::pair<SDL_Rect, std::string>> drawn_;
};

void disc(SDL_Renderer* r, int cx, int cy, int rad) {
    for (int dy = -rad; dy <= rad; ++dy) {
        int dx = 0;
        while ((dx + 1) * (dx + 1) + dy * dy <= rad * rad) ++dx;
        SDL_RenderDrawLine(r, cx - dx, cy + dy, cx + dx, cy + dy);
    }
}

// The moving bodies' positions after each of the last two ticks, for drawing between them.
struct TickPositions {
    std::vector<Vec3> previous, current;
    void record(const lockroll::sim::World& w) {
        previous.swap(current);
        current.resize(w.body_count());
        for (lockroll::sim::BodyId id = 0; id < w.body_count(); ++id) current[id] = w.position(id);
        if (previous.size() != current.size()) previous = current;
    }
};

// a + (b - a) * t, for drawing only (the simulation never sees it).
Fixed blend(Fixed a, Fixed b, double t) {
    return Fixed::from_raw(a.raw + static_cast<std::int64_t>(static_cast<double>(b.raw - a.raw) * t));
}

void draw_world(SDL_Renderer* r, const lockroll::sim::SceneDesc& scene, const lockroll::sim::World& w, const TickPositions& ticks,
                double interpolation) {
    SDL_SetRenderDrawColor(r, 28, 30, 40, 255);
    SDL_RenderClear(r);
    for (lockroll::sim::BodyId id = 0; id < w.body_count() && id < scene.bodies.size(); ++id) {
        const auto& d = scene.bodies[id];
        Vec3 p = w.position(id);
        if (!w.is_static(id) && id < ticks.current.size()) {
            const Vec3 &a = ticks.previous[id], &b = ticks.current[id];
            p = {blend(a.x, b.x, interpolation), blend(a.y, b.y, interpolation), blend(a.z, b.z, interpolation)};
        }
        if (d.shape == lockroll::sim::Shape::Sphere) {
            SDL_SetRenderDrawColor(r, 240, 200, 40, 255);
            disc(r, px(p.x), py(p.z), static_cast<int>((d.radius.raw * kScale) >> 32));
            continue;
        }
        if (w.is_static(id) && (p.y < q(0) || p.y > q(5))) continue;  // floor and ceiling
        if (w.is_static(id)) SDL_SetRenderDrawColor(r, 128, 128, 136, 255);
        else if (d.player == 0) SDL_SetRenderDrawColor(r, 60, 120, 255, 255);
        else SDL_SetRenderDrawColor(r, 230, 60, 60, 255);
        const int x0 = px(p.x - d.half_extents.x), x1 = px(p.x + d.half_extents.x);
        const int y0 = py(p.z + d.half_extents.z), y1 = py(p.z - d.half_extents.z);
        SDL_Rect rect{x0, y0, x1 - x0, y1 - y0};
        SDL_RenderFillRect(r, &rect);
    }
}

int usage(const std::string& why) {
    std::fprintf(stderr, "room: %s\nusage: room SLOT(0|1) MY_PORT PEER_PORT [--frames N] [--delay D] [--window W] [--fps F] [--bot] "
                         "[--font FILE] [--screenshot FILE --shot-frame F]\n", why.c_str());
    return 2;
}

// `text` as a whole decimal number in [lo, hi], or nothing (the caller names what it was for).
std::optional<long> whole(const char* text, long lo, long hi) {
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(text, &end, 10);
    if (end == text || *end != '\0' || errno != 0 || v < lo || v > hi) return std::nullopt;
    return v;
}

// Debian's fonts-dejavu-core puts it here; fontconfig (fc-match) is not assumed.
constexpr const char* kDefaultFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
constexpr int kFontPoints = 15;

struct TtfFontCloser {
    void operator()(TTF_Font* f) const { TTF_CloseFont(f); }
};

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4) return usage("missing arguments");
    long frames = 0, delay = 2, window = 8, shot_frame = -1, fps = 144;
    bool bot = false;
    std::string shot, font_path;
    struct Positional {
        const char* name;
        long lo, hi;
        long value = 0;
    } positional[] = {{"SLOT", 0, 1}, {"MY_PORT", 1, 65535}, {"PEER_PORT", 1, 65535}};
    for (int i = 0; i < 3; ++i) {
        const auto& p = positional[i];
        const auto v = whole(argv[i + 1], p.lo, p.hi);
        if (!v) return usage(std::string(p.name) + " '" + argv[i + 1] + "': must be a whole number in " + std::to_string(p.lo) +
                             ".." + std::to_string(p.hi));
        positional[i].value = *v;
    }
    const int slot = static_cast<int>(positional[0].value);
    const long my_port = positional[1].value, peer_port = positional[2].value;
    struct Flag {
        const char* name;
        long* value;
        long lo, hi;
    } const numbers[] = {{"--frames", &frames, 0, 100000000}, {"--delay", &delay, 0, 1000}, {"--window", &window, 0, 1000},
                         {"--fps", &fps, 1, 1000},            {"--shot-frame", &shot_frame, 0, 100000000}};
    for (int i = 4; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has = i + 1 < argc;
        const auto number = std::find_if(std::begin(numbers), std::end(numbers), [&](const Flag& f) { return a == f.name; });
        if (a == "--bot") {
            bot = true;
        } else if (number != std::end(numbers) && has) {
            const auto v = whole(argv[++i], number->lo, number->hi);
            if (!v) return usage(a + " '" + argv[i] + "': must be a whole number in " + std::to_string(number->lo) + ".." +
                                 std::to_string(number->hi));
            *number->value = *v;
        } else if (a == "--screenshot" && has) {
            shot = argv[++i];
        } else if (a == "--font" && has) {
            font_path = argv[++i];
        } else {
            return usage("unknown or incomplete option " + a);
        }
    }
    if (!shot.empty() && shot_frame < 0) return usage("--screenshot needs --shot-frame");

    // The overlay's font, before any work starts: a --font that does not open is bad input (exit
    // 2); the default missing only costs the overlay its words, said once here.
    std::unique_ptr<TTF_Font, TtfFontCloser> font;
    if (TTF_Init() != 0) {
        if (!font_path.empty()) return usage("--font " + font_path + ": SDL2_ttf did not start: " + TTF_GetError());
        std::fprintf(stderr, "room: SDL2_ttf did not start (%s); the overlay shows bars without words\n", TTF_GetError());
    } else {
        font.reset(TTF_OpenFont(font_path.empty() ? kDefaultFont : font_path.c_str(), kFontPoints));
        if (!font && !font_path.empty()) return usage("--font " + font_path + ": " + TTF_GetError());
        if (!font)
            std::fprintf(stderr,
                         "room: no font at %s (Debian package fonts-dejavu-core, or --font FILE): the overlay shows bars "
                         "without words\n",
                         kDefaultFont);
    }

    const lockroll::sim::SceneDesc scene = paper_scene();
    lockroll::rollback::WorldSimulation game(scene, 2);
    std::unique_ptr<lockroll::net::NetSession> net;
    try {
        net = lockroll::net::SessionBuilder()
                  .players(2)
                  .input_size(lockroll::rollback::kWorldInputSize)
                  .local_player(static_cast<lockroll::rollback::PlayerId>(slot))
                  .remote_player(static_cast<lockroll::rollback::PlayerId>(1 - slot), "127.0.0.1",
                                 static_cast<std::uint16_t>(peer_port))
                  .listen("127.0.0.1", static_cast<std::uint16_t>(my_port))
                  .input_delay(static_cast<int>(delay))
                  .prediction_window(static_cast<int>(window))
                  .match_id(0x700d)
                  .frames(static_cast<std::uint32_t>(frames))
                  .start(game);
    } catch (const std::exception& e) {
        return usage(e.what());
    }

    if (SDL_Init(SDL_INIT_VIDEO) != 0) return std::fprintf(stderr, "room: SDL_Init: %s\n", SDL_GetError()), 1;
    SDL_Window* win = SDL_CreateWindow(slot == 0 ? "lockroll room: player 0 (blue)" : "lockroll room: player 1 (red)",
                                       SDL_WINDOWPOS_UNDEFINED, SDL_WINDOWPOS_UNDEFINED, kSize, kTop + kSize, 0);
    SDL_Renderer* ren = win ? SDL_CreateRenderer(win, -1, SDL_RENDERER_SOFTWARE) : nullptr;
    if (!ren) return std::fprintf(stderr, "room: SDL window: %s\n", SDL_GetError()), 1;

    // Sees every tick run inside update(): the rollback depth for the overlay, and the moving
    // bodies' positions for drawing between ticks.
    struct Ticks : lockroll::net::RunnerObserver {
        explicit Ticks(const lockroll::rollback::WorldSimulation& g) : game(g) { positions.record(g.world()); }
        void on_tick(const lockroll::net::TickReport& t) override {
            if (t.advance.rollback_depth > 0) depth = t.advance.rollback_depth;
            positions.record(game.world());
        }
        const lockroll::rollback::WorldSimulation& game;
        TickPositions positions;
        long depth = 0;
    } ticks(game);
    bool lockstep_view = false, shot_taken = false;
    auto overlay = std::make_unique<Overlay>(font.get());  // freed before the renderer: its textures are the renderer's
    const auto other = static_cast<lockroll::rollback::PlayerId>(1 - slot);
    // Called once per tick inside update(): this tick's input, from the keys SDL last pumped.
    const lockroll::net::InputSource input = [&](std::uint32_t frame, std::span<std::uint8_t> out) {
        lockroll::sim::PlayerInput in;
        if (bot) {  // circles the room, a different way per slot
            const int phase = static_cast<int>(frame / 45 + static_cast<std::uint32_t>(slot) * 2) % 4;
            in.forward = static_cast<std::int8_t>(phase == 0 ? 127 : phase == 2 ? -127 : 0);
            in.right = static_cast<std::int8_t>(phase == 1 ? 127 : phase == 3 ? -127 : 0);
        } else {
            const Uint8* k = SDL_GetKeyboardState(nullptr);
            in.forward = static_cast<std::int8_t>((k[SDL_SCANCODE_UP] || k[SDL_SCANCODE_W] ? 127 : 0) -
                                                  (k[SDL_SCANCODE_DOWN] || k[SDL_SCANCODE_S] ? 127 : 0));
            in.right = static_cast<std::int8_t>((k[SDL_SCANCODE_RIGHT] || k[SDL_SCANCODE_D] ? 127 : 0) -
                                                (k[SDL_SCANCODE_LEFT] || k[SDL_SCANCODE_A] ? 127 : 0));
            in.up = static_cast<std::int8_t>(k[SDL_SCANCODE_SPACE] ? 127 : 0);
        }
        const auto bytes = lockroll::rollback::encode_input(in);
        std::copy(bytes.begin(), bytes.end(), out.begin());
    };
    // The game's loop: events, one update(), draw, then sleep until the next frame is due.
    const auto frame_time = std::chrono::microseconds(1000000 / fps);
    auto next = std::chrono::steady_clock::now();
    lockroll::net::RunOutcome outcome{};
    for (;;) {
        for (SDL_Event e; SDL_PollEvent(&e);) {
            if (e.type == SDL_QUIT || (e.type == SDL_KEYDOWN && e.key.keysym.sym == SDLK_ESCAPE)) net->request_stop();
            if (e.type == SDL_KEYDOWN && e.key.keysym.sym == SDLK_l && !e.key.repeat) {
                // A real switch: this client stops running on guesses (window 0) or resumes.
                lockstep_view = !lockstep_view;
                net->session().set_prediction_window(lockstep_view ? 0 : static_cast<int>(window));
            }
        }
        const lockroll::net::UpdateResult r = net->update(input, &ticks);
        if (r.outcome) {
            outcome = *r.outcome;
            break;
        }
        const auto& s = net->session();
        draw_world(ren, scene, game.world(), ticks.positions, r.interpolation);
        const auto st = net->network_stats(other);
        overlay->draw(ren, {.ping_ms = static_cast<long>(st.ping_us / 1000),
                           .input_delay = s.input_delay(),
                           .rollback_frames = ticks.depth,
                           .frames_behind = st.frames_behind,
                           .window = window,
                           .lockstep = lockstep_view});
        if (!shot.empty() && !shot_taken && s.frame() >= static_cast<std::uint32_t>(shot_frame)) {
            shot_taken = true;  // read back before presenting: the back buffer is then undefined
            if (SDL_Surface* img = SDL_CreateRGBSurfaceWithFormat(0, kSize, kTop + kSize, 32, SDL_PIXELFORMAT_ARGB8888)) {
                SDL_RenderReadPixels(ren, nullptr, SDL_PIXELFORMAT_ARGB8888, img->pixels, img->pitch);
                SDL_SaveBMP(img, shot.c_str());
                SDL_FreeSurface(img);
            }
            overlay->report(stdout);
        }
        SDL_RenderPresent(ren);
        next += frame_time;
        const auto now = std::chrono::steady_clock::now();
        if (next < now) next = now;  // a slow frame is not made up in a burst
        std::this_thread::sleep_until(next);
    }
    overlay.reset();
    SDL_DestroyRenderer(ren);
    SDL_DestroyWindow(win);
    SDL_Quit();
    font.reset();
    TTF_Quit();
    const auto last = frames > 0 ? net->session().confirmed_checksum(static_cast<std::uint32_t>(frames)) : std::nullopt;
    std::printf("slot %d %s frame %ld checksum %016llx\n", slot, lockroll::net::outcome_name(outcome), frames,
                last ? static_cast<unsigned long long>(*last) : 0ull);
    return outcome == lockroll::net::RunOutcome::Completed || outcome == lockroll::net::RunOutcome::Stopped ? 0 : 1;
}
