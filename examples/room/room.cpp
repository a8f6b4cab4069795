// The seed paper's scene as a playable program: a closed room, two player boxes and 50 balls,
// seen from above (like the paper's Figure 7), two players over ENet.
//
//   room SLOT MY_PORT PEER_PORT [--frames N] [--delay D] [--window W] [--fps F] [--bot]
//        [--screenshot FILE --shot-frame F]
//
// The game owns its loop: it draws at its own rate (--fps, default 144; the match ticks at 60 Hz)
// and calls NetSession::update() once per drawn frame. Between ticks it draws the moving bodies
// blended between the last two ticks' positions by the update's interpolation fraction, so a
// 144 Hz window moves smoothly on a 60 Hz simulation.
//
// Keys: arrows or WASD move, space lifts, L toggles this client between rollback (runs ahead on
// predictions, up to --window frames) and lockstep (prediction window 0: a frame runs once its
// inputs are confirmed; set_prediction_window), Esc quits.
// The overlay (SDL has no text; bars and digits drawn here): ping (ms), input delay (frames),
// rollback depth (frames, newest), frames behind the peer, and the view (R or L).
// --bot plays by itself (tests); --screenshot saves the window as BMP once frame F is shown.
// Prints the confirmed checksum of the last frame, which both windows must agree on.
#include <SDL.h>

#include <lockroll/net/session_builder.h>
#include <lockroll/rollback/world_simulation.h>
#include <lockroll/sim/scene.h>
#include <lockroll/sim/world.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
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

// A 3x5 font for the overlay: digits and the few letters it uses.
const char* glyph(char c) {
    switch (c) {
        case '0': return "111101101101111"; case '1': return "010110010010111"; case '2': return "111001111100111";
        case '3': return "111001111001111"; case '4': return "101101111001001"; case '5': return "111100111001111";
        case '6': return "111100111101111"; case '7': return "111001010010010"; case '8': return "111101111101111";
        case '9': return "111101111001111"; case 'P': return "111101111100100"; case 'D': return "110101101101110";
        case 'R': return "110101110101101"; case 'B': return "110101110101110"; case 'L': return "100100100100111";
        default: return "000000000000000";
    }
}
void text(SDL_Renderer* r, int x, int y, const std::string& s, int dot = 3) {
    for (char c : s) {
        const char* g = glyph(c);
        for (int i = 0; i < 15; ++i)
            if (g[i] == '1') {
                SDL_Rect d{x + (i % 3) * dot, y + (i / 3) * dot, dot, dot};
                SDL_RenderFillRect(r, &d);
            }
        x += 4 * dot;
    }
}
// Label, value, and a bar of value out of full.
void gauge(SDL_Renderer* r, int x, const char* label, long value, long full) {
    SDL_SetRenderDrawColor(r, 220, 220, 220, 255);
    text(r, x, 10, label);
    text(r, x + 30, 10, std::to_string(std::max(0L, value)));
    SDL_SetRenderDrawColor(r, 60, 60, 60, 255);
    SDL_Rect back{x, 40, 150, 12};
    SDL_RenderFillRect(r, &back);
    SDL_SetRenderDrawColor(r, 80, 200, 90, 255);
    SDL_Rect bar{x, 40, static_cast<int>(150 * std::clamp(value, 0L, full) / full), 12};
    SDL_RenderFillRect(r, &bar);
}

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

int usage(const char* why) {
    std::fprintf(stderr, "room: %s\nusage: room SLOT(0|1) MY_PORT PEER_PORT [--frames N] [--delay D] [--window W] [--fps F] [--bot] "
                         "[--screenshot FILE --shot-frame F]\n", why);
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4) return usage("missing arguments");
    const int slot = std::atoi(argv[1]);
    const long my_port = std::atol(argv[2]), peer_port = std::atol(argv[3]);
    long frames = 0, delay = 2, window = 8, shot_frame = -1, fps = 144;
    bool bot = false;
    std::string shot;
    for (int i = 4; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has = i + 1 < argc;
        if (a == "--bot") bot = true;
        else if (a == "--frames" && has) frames = std::atol(argv[++i]);
        else if (a == "--delay" && has) delay = std::atol(argv[++i]);
        else if (a == "--window" && has) window = std::atol(argv[++i]);
        else if (a == "--fps" && has) fps = std::atol(argv[++i]);
        else if (a == "--screenshot" && has) shot = argv[++i];
        else if (a == "--shot-frame" && has) shot_frame = std::atol(argv[++i]);
        else return usage(("unknown or incomplete option " + a).c_str());
    }
    if ((slot != 0 && slot != 1) || my_port < 1 || my_port > 65535 || peer_port < 1 || peer_port > 65535 || frames < 0)
        return usage("bad slot, port or frame count");
    if (!shot.empty() && shot_frame < 0) return usage("--screenshot needs --shot-frame");
    if (fps < 1 || fps > 1000) return usage(("--fps " + std::to_string(fps) + ": must be 1..1000").c_str());

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
        gauge(ren, 10, "P", static_cast<long>(st.ping_us / 1000), 200);
        gauge(ren, 180, "D", s.input_delay(), 10);
        gauge(ren, 350, "RB", ticks.depth, std::max(window, 1L));
        gauge(ren, 520, "B", st.frames_behind, 10);
        SDL_SetRenderDrawColor(ren, 255, 255, 255, 255);
        text(ren, kSize - 30, 10, lockstep_view ? "L" : "R", 5);
        if (!shot.empty() && !shot_taken && s.frame() >= static_cast<std::uint32_t>(shot_frame)) {
            shot_taken = true;  // read back before presenting: the back buffer is then undefined
            if (SDL_Surface* img = SDL_CreateRGBSurfaceWithFormat(0, kSize, kTop + kSize, 32, SDL_PIXELFORMAT_ARGB8888)) {
                SDL_RenderReadPixels(ren, nullptr, SDL_PIXELFORMAT_ARGB8888, img->pixels, img->pitch);
                SDL_SaveBMP(img, shot.c_str());
                SDL_FreeSurface(img);
            }
        }
        SDL_RenderPresent(ren);
        next += frame_time;
        const auto now = std::chrono::steady_clock::now();
        if (next < now) next = now;  // a slow frame is not made up in a burst
        std::this_thread::sleep_until(next);
    }
    SDL_DestroyRenderer(ren);
    SDL_DestroyWindow(win);
    SDL_Quit();
    const auto last = frames > 0 ? net->session().confirmed_checksum(static_cast<std::uint32_t>(frames)) : std::nullopt;
    std::printf("slot %d %s frame %ld checksum %016llx\n", slot, lockroll::net::outcome_name(outcome), frames,
                last ? static_cast<unsigned long long>(*last) : 0ull);
    return outcome == lockroll::net::RunOutcome::Completed || outcome == lockroll::net::RunOutcome::Stopped ? 0 : 1;
}
