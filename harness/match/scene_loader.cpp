#include "harness/match/scene_loader.h"

#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

namespace lockroll::harness {

namespace {
using nlohmann::json;

// Builds the usual DOM, except that every non-integer number keeps its decimal text: it is
// stored as a binary value, a type JSON text itself can never produce, so it cannot be
// confused with a string.
class DecimalSax : public nlohmann::detail::json_sax_dom_parser<json> {
public:
    using nlohmann::detail::json_sax_dom_parser<json>::json_sax_dom_parser;
    bool number_float(json::number_float_t, const json::string_t& text) {
        json::binary_t b(std::vector<std::uint8_t>(text.begin(), text.end()));
        return binary(b);
    }
    // Syntax errors, and numbers nlohmann cannot hold (1e400 overflows a double before
    // number_float sees it): kept with their byte offset instead of thrown, so the message can
    // name the line and column.
    template <class Exception>
    bool parse_error(std::size_t position, const std::string& token, const Exception& ex) {
        error_position = position;
        error_token = token;
        error_what = ex.what();
        error_is_number = ex.id == 406;
        return false;
    }
    std::size_t error_position = 0;
    std::string error_token, error_what;
    bool error_is_number = false;
};

// "line L, column C" of a byte offset (1-based, as editors count).
std::string line_column(const std::string& text, std::size_t offset) {
    offset = std::min(offset, text.size());
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i < offset; ++i) {
        if (text[i] == '\n') {
            ++line;
            column = 1;
        } else {
            ++column;
        }
    }
    return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

// Reading context: the origin and the JSON pointer of the value being read.
class Reader {
public:
    Reader(const json& value, std::string origin, std::string path)
        : v_(value), origin_(std::move(origin)), path_(std::move(path)) {}

    [[noreturn]] void fail(const std::string& what) const {
        throw SceneError(origin_ + ": " + (path_.empty() ? "/" : path_) + ": " + what);
    }

    Reader at(const std::string& key) const {
        if (!v_.is_object()) fail("expected an object");
        if (!v_.contains(key)) fail("missing required key \"" + key + "\"");
        return Reader(v_.at(key), origin_, path_ + "/" + key);
    }
    Reader at(std::size_t i) const { return Reader(v_.at(i), origin_, path_ + "/" + std::to_string(i)); }
    bool has(const std::string& key) const { return v_.contains(key); }
    const json& raw() const { return v_; }
    bool boolean() const {
        if (!v_.is_boolean()) fail("expected true or false");
        return v_.get<bool>();
    }

    // Object with only the given keys; a typo in a scene file must not pass silently.
    void expect_object(std::initializer_list<const char*> keys) const {
        if (!v_.is_object()) fail("expected an object");
        std::set<std::string> allowed(keys.begin(), keys.end());
        for (auto it = v_.begin(); it != v_.end(); ++it)
            if (!allowed.count(it.key())) fail("unknown key \"" + it.key() + "\"");
    }

    std::size_t array_size() const {
        if (!v_.is_array()) fail("expected an array");
        return v_.size();
    }

    sim::Fixed fixed() const {
        if (v_.is_binary()) {
            const auto& b = v_.get_binary();
            const std::string text(b.begin(), b.end());
            if (auto f = sim::Fixed::parse(text)) return *f;
            fail("number " + text + " is outside the Q32.32 range (|x| < 2147483648) or has over 64 significant digits");
        }
        if (v_.is_number_integer()) {
            const auto i = v_.get<std::int64_t>();
            if (i < -(std::int64_t{1} << 31) || i >= (std::int64_t{1} << 31))
                fail("number " + std::to_string(i) + " is outside the Q32.32 range (|x| < 2147483648)");
            return sim::Fixed::from_raw(i * sim::Fixed::kOne);
        }
        if (v_.is_number_unsigned()) fail("number is outside the Q32.32 range (|x| < 2147483648)");
        fail("expected a number");
    }

    sim::Fixed fixed_in(const char* lo_text, const char* hi_text) const {
        const sim::Fixed f = fixed(), lo = *sim::Fixed::parse(lo_text), hi = *sim::Fixed::parse(hi_text);
        if (f < lo || f > hi) fail("must be within [" + std::string(lo_text) + ", " + hi_text + "], got " + f.to_string());
        return f;
    }

    std::int64_t integer(std::int64_t lo, std::int64_t hi) const {
        if (!v_.is_number_integer()) fail("expected an integer");
        const auto i = v_.get<std::int64_t>();
        if (i < lo || i > hi) fail("must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
        return i;
    }

    std::uint64_t seed() const {
        if (!v_.is_number_integer() || (v_.is_number_integer() && !v_.is_number_unsigned() && v_.get<std::int64_t>() < 0))
            fail("expected a non-negative integer seed");
        return v_.get<std::uint64_t>();
    }

    std::string string() const {
        if (!v_.is_string()) fail("expected a string");
        return v_.get<std::string>();
    }

    sim::Vec3 vec3() const {
        if (!v_.is_array() || v_.size() != 3) fail("expected an array of 3 numbers [x, y, z]");
        return {at(0).fixed(), at(1).fixed(), at(2).fixed()};
    }

    sim::Shape shape() const {
        const std::string s = string();
        if (s == "sphere") return sim::Shape::Sphere;
        if (s == "box") return sim::Shape::Box;
        if (s == "capsule") return sim::Shape::Capsule;
        fail("unknown shape \"" + s + "\" (sphere, box, capsule)");
    }

private:
    const json& v_;
    std::string origin_;
    std::string path_;
};

struct Material {
    std::optional<sim::Fixed> restitution;
    std::optional<sim::Fixed> friction, static_friction;
};

// Fields shared by bodies and spawners: shape and size, mass, gravity scale, restitution.
template <class Desc>
void read_common(const Reader& r, const std::map<std::string, Material>& materials, Desc& d) {
    d.shape = r.at("shape").shape();
    switch (d.shape) {
        case sim::Shape::Sphere:
            d.radius = r.at("radius").fixed();
            if (d.radius.raw <= 0) r.at("radius").fail("must be > 0");
            break;
        case sim::Shape::Capsule:
            d.radius = r.at("radius").fixed();
            if (d.radius.raw <= 0) r.at("radius").fail("must be > 0");
            d.half_height = r.at("half_height").fixed();
            if (d.half_height.raw < 0) r.at("half_height").fail("must be >= 0");
            break;
        case sim::Shape::Box:
            d.half_extents = r.at("half_extents").vec3();
            if (d.half_extents.x.raw <= 0 || d.half_extents.y.raw <= 0 || d.half_extents.z.raw <= 0)
                r.at("half_extents").fail("every half extent must be > 0");
            break;
    }
    if (r.has("mass")) {
        d.mass = r.at("mass").fixed();
        if (d.mass.raw < 0) r.at("mass").fail("must be >= 0 (0 makes the body static)");
    }
    if (r.has("gravity_scale")) d.gravity_scale = r.at("gravity_scale").fixed();
    if (r.has("material")) {
        const std::string name = r.at("material").string();
        auto it = materials.find(name);
        if (it == materials.end()) r.at("material").fail("no material named \"" + name + "\"");
        d.restitution = it->second.restitution;
        if (it->second.friction) d.friction = it->second.friction;
        if (it->second.static_friction) d.static_friction = it->second.static_friction;
    }
    if (r.has("restitution")) d.restitution = r.at("restitution").fixed_in("0", "1");
    if (r.has("friction")) d.friction = r.at("friction").fixed_in("0", "10");
    if (r.has("static_friction")) d.static_friction = r.at("static_friction").fixed_in("0", "10");
}

// {"SHAPE-SHAPE": value, ...} into a symmetric table by shape, each value within [0, hi].
void read_pair_table(const Reader& t, const char* hi, sim::Fixed (&table)[sim::kShapeCount][sim::kShapeCount]) {
    for (auto it = t.raw().begin(); it != t.raw().end(); ++it) {
        const std::string key = it.key();
        const auto dash = key.find('-');
        const Reader e = t.at(key);
        auto parse_shape = [&](const std::string& s) {
            if (s == "sphere") return 0;
            if (s == "box") return 1;
            if (s == "capsule") return 2;
            e.fail("key must be SHAPE-SHAPE with shapes sphere, box, capsule");
        };
        if (dash == std::string::npos) e.fail("key must be SHAPE-SHAPE, e.g. \"sphere-box\"");
        const int a = parse_shape(key.substr(0, dash)), b = parse_shape(key.substr(dash + 1));
        table[a][b] = table[b][a] = e.fixed_in("0", hi);
    }
}

// "sleeping": true (the default thresholds) or {"linear_speed", "angular_speed", "time"}.
void read_sleeping(const Reader& r, sim::RigidDesc::Sleeping& sl) {
    sl.enabled = true;
    if (r.raw().is_boolean()) {
        sl.enabled = r.raw().get<bool>();
        return;
    }
    r.expect_object({"linear_speed", "angular_speed", "time"});
    // The lower bounds are exclusive (sim::validate): 0 is rejected there with its field's name.
    if (r.has("linear_speed")) sl.linear_speed = r.at("linear_speed").fixed_in("0", "100");
    if (r.has("angular_speed")) sl.angular_speed = r.at("angular_speed").fixed_in("0", "100");
    if (r.has("time")) sl.time = r.at("time").fixed_in("0", "60");
}

// A rigid scene's bodies may turn and rub; every key of "rigid" defaults to sim::RigidDesc.
void read_rigid(const Reader& r, sim::RigidDesc& rg) {
    rg.enabled = true;
    if (r.raw().is_boolean()) {
        rg.enabled = r.raw().get<bool>();
        return;
    }
    r.expect_object({"friction", "static_friction", "linear_damping", "angular_damping", "baumgarte", "slop",
                     "restitution_threshold", "shock_propagation", "warm_starting", "split_impulse",
                     "reduce_manifold", "block_solver", "graph_colouring", "sleeping",
                     "spinning_friction", "rolling_friction"});
    auto table = [&](const char* key, sim::Fixed (&t)[sim::kShapeCount][sim::kShapeCount]) {
        const Reader tr = r.at(key);
        if (tr.raw().is_object()) {
            read_pair_table(tr, "10", t);
        } else {  // one number for every pair
            const sim::Fixed v = tr.fixed_in("0", "10");
            for (auto& row : t)
                for (auto& x : row) x = v;
        }
    };
    if (r.has("friction")) {
        table("friction", rg.friction);
        if (!r.has("static_friction")) table("friction", rg.static_friction);
    }
    if (r.has("static_friction")) table("static_friction", rg.static_friction);
    if (r.has("linear_damping")) rg.linear_damping = r.at("linear_damping").fixed_in("0", "1000");
    if (r.has("angular_damping")) rg.angular_damping = r.at("angular_damping").fixed_in("0", "1000");
    if (r.has("baumgarte")) rg.baumgarte = r.at("baumgarte").fixed_in("0", "1");
    if (r.has("slop")) rg.slop = r.at("slop").fixed_in("0", "1");
    if (r.has("restitution_threshold")) rg.restitution_threshold = r.at("restitution_threshold").fixed_in("0", "1000");
    if (r.has("shock_propagation")) rg.shock_propagation = r.at("shock_propagation").boolean();
    if (r.has("warm_starting")) rg.warm_starting = r.at("warm_starting").boolean();
    if (r.has("split_impulse")) rg.split_impulse = r.at("split_impulse").boolean();
    if (r.has("reduce_manifold")) rg.reduce_manifold = r.at("reduce_manifold").boolean();
    if (r.has("block_solver")) rg.block_solver = r.at("block_solver").boolean();
    if (r.has("graph_colouring")) rg.graph_colouring = r.at("graph_colouring").boolean();
    if (r.has("sleeping")) read_sleeping(r.at("sleeping"), rg.sleeping);
    // Lengths in metres (torque per unit normal force); sim::validate bounds them again.
    if (r.has("spinning_friction")) rg.spinning_friction = r.at("spinning_friction").fixed_in("0", "1");
    if (r.has("rolling_friction")) rg.rolling_friction = r.at("rolling_friction").fixed_in("0", "1");
}

// Rigid-only body keys: a clear message when the scene is not rigid.
void read_rigid_body(const Reader& b, const sim::SceneDesc& scene, sim::BodyDesc& d) {
    for (const char* key : {"orientation", "angular_velocity", "linear_damping", "angular_damping", "friction",
                            "static_friction"})
        if (b.has(key) && !scene.rigid.enabled) b.at(key).fail("needs a rigid scene (top-level \"rigid\")");
    if (b.has("orientation")) {
        const Reader o = b.at("orientation");
        if (!o.raw().is_array() || o.raw().size() != 4) o.fail("expected a unit quaternion [w, x, y, z]");
        d.orientation = {o.at(0).fixed_in("-1", "1"), o.at(1).fixed_in("-1", "1"), o.at(2).fixed_in("-1", "1"),
                         o.at(3).fixed_in("-1", "1")};
        if (d.orientation == sim::Quat{sim::Fixed::zero(), sim::Fixed::zero(), sim::Fixed::zero(), sim::Fixed::zero()})
            o.fail("must not be zero");
    }
    if (b.has("angular_velocity")) d.angular_velocity = b.at("angular_velocity").vec3();
    if (b.has("linear_damping")) d.linear_damping = b.at("linear_damping").fixed_in("0", "1000");
    if (b.has("angular_damping")) d.angular_damping = b.at("angular_damping").fixed_in("0", "1000");
}

constexpr auto kBodyKeys = {"shape", "position", "velocity", "radius", "half_extents", "half_height",
                            "mass", "gravity_scale", "restitution", "material", "player", "orientation",
                            "angular_velocity", "friction", "static_friction", "linear_damping", "angular_damping"};
constexpr auto kSpawnerKeys = {"count", "shape", "radius", "half_extents", "half_height", "mass",
                               "gravity_scale", "restitution", "material", "region", "max_speed", "seed",
                               "friction", "static_friction"};

// Opt-in solver features (docs/stability.md); every key defaults to the seed paper's solver.
void read_solver(const Reader& r, sim::SolverDesc& sv) {
    r.expect_object({"substeps", "integrator", "correction", "slop", "max_push_speed", "restitution_threshold",
                     "restitution_after", "position_based", "shock_propagation", "continuous", "continuous_min_speed"});
    auto flag = [&](const char* key) { return r.at(key).boolean(); };
    if (r.has("substeps")) sv.substeps = static_cast<int>(r.at("substeps").integer(1, 64));
    if (r.has("integrator")) {
        const std::string i = r.at("integrator").string();
        if (i == "euler") sv.integrator = sim::Integrator::Euler;
        else if (i == "ballistic") sv.integrator = sim::Integrator::Ballistic;
        else r.at("integrator").fail("expected \"euler\" or \"ballistic\"");
    }
    if (r.has("correction")) {
        sv.correction = r.at("correction").fixed_in("0", "1");
        if (sv.correction.raw == 0) r.at("correction").fail("must be > 0");
    }
    if (r.has("slop")) sv.slop = r.at("slop").fixed_in("0", "1");
    if (r.has("max_push_speed")) sv.max_push_speed = r.at("max_push_speed").fixed_in("0", "100000");
    if (r.has("restitution_threshold")) sv.restitution_threshold = r.at("restitution_threshold").fixed_in("0", "1000");
    if (r.has("restitution_after")) sv.restitution_after = flag("restitution_after");
    if (r.has("position_based")) sv.position_based = flag("position_based");
    if (r.has("shock_propagation")) sv.shock_propagation = flag("shock_propagation");
    if (r.has("continuous")) sv.continuous = flag("continuous");
    if (r.has("continuous_min_speed")) sv.continuous_min_speed = r.at("continuous_min_speed").fixed_in("0", "1000");
}

sim::SceneDesc read_scene(const Reader& r) {
    r.expect_object({"name", "description", "tick_rate", "iterations", "gravity", "contact_margin",
                     "broadphase", "restitution", "materials", "controller", "solver", "rigid", "room", "bodies",
                     "spawners"});
    sim::SceneDesc scene;
    if (r.has("name")) scene.name = r.at("name").string();
    if (r.has("tick_rate")) scene.tick_rate = static_cast<int>(r.at("tick_rate").integer(1, 1000));
    if (r.has("iterations")) scene.iterations = static_cast<int>(r.at("iterations").integer(1, 64));
    if (r.has("gravity")) scene.gravity = r.at("gravity").vec3();
    if (r.has("contact_margin")) {
        scene.contact_margin = r.at("contact_margin").fixed();
        if (scene.contact_margin.raw < 0) r.at("contact_margin").fail("must be >= 0");
    }
    if (r.has("broadphase")) {
        const std::string b = r.at("broadphase").string();
        if (b == "auto") scene.broadphase = sim::BroadphaseKind::Auto;
        else if (b == "sap") scene.broadphase = sim::BroadphaseKind::SweepAndPrune;
        else if (b == "grid") scene.broadphase = sim::BroadphaseKind::Grid;
        else r.at("broadphase").fail("expected \"auto\", \"sap\" or \"grid\"");
    }
    if (r.has("restitution")) {
        const Reader t = r.at("restitution");
        if (!t.raw().is_object()) t.fail("expected an object such as {\"sphere-box\": 0.8}");
        read_pair_table(t, "1", scene.restitution);
    }
    std::map<std::string, Material> materials;
    if (r.has("materials")) {
        const Reader m = r.at("materials");
        if (!m.raw().is_object()) m.fail("expected an object of named materials");
        for (auto it = m.raw().begin(); it != m.raw().end(); ++it) {
            const Reader one = m.at(it.key());
            one.expect_object({"restitution", "friction", "static_friction"});
            Material mat;
            if (one.has("restitution")) mat.restitution = one.at("restitution").fixed_in("0", "1");
            if (one.has("friction")) mat.friction = one.at("friction").fixed_in("0", "10");
            if (one.has("static_friction")) mat.static_friction = one.at("static_friction").fixed_in("0", "10");
            materials[it.key()] = mat;
        }
    }
    if (r.has("controller")) {
        const Reader c = r.at("controller");
        c.expect_object({"max_speed", "acceleration", "vertical_acceleration"});
        if (c.has("max_speed")) scene.controller.max_speed = c.at("max_speed").fixed_in("0", "1000");
        if (c.has("acceleration")) scene.controller.acceleration = c.at("acceleration").fixed_in("0", "100000");
        if (c.has("vertical_acceleration"))
            scene.controller.vertical_acceleration = c.at("vertical_acceleration").fixed_in("0", "100000");
    }
    if (r.has("solver")) read_solver(r.at("solver"), scene.solver);
    if (r.has("rigid")) read_rigid(r.at("rigid"), scene.rigid);
    if (r.has("room")) {
        const Reader room = r.at("room");
        room.expect_object({"min", "max", "wall"});
        const sim::Vec3 lo = room.at("min").vec3(), hi = room.at("max").vec3();
        if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z)) room.fail("min must be below max on every axis");
        sim::Fixed wall = sim::Fixed::one();
        if (room.has("wall")) {
            wall = room.at("wall").fixed();
            if (wall.raw <= 0) room.at("wall").fail("must be > 0");
        }
        sim::add_room(scene, lo, hi, wall);
    }
    // Counted before anything is expanded: a few bytes of spawner must not cost unbounded memory.
    const std::size_t limit = max_scene_bodies();
    auto check_total = [&](const Reader& where, std::size_t adding) {
        if (adding > limit || scene.bodies.size() > limit - adding)
            where.fail("the scene would have " + std::to_string(scene.bodies.size() + adding) +
                       " bodies, more than the limit of " + std::to_string(limit) + " (lockroll --max-bodies N)");
    };
    if (r.has("bodies")) {
        const Reader bodies = r.at("bodies");
        check_total(bodies, bodies.array_size());
        for (std::size_t i = 0; i < bodies.array_size(); ++i) {
            const Reader b = bodies.at(i);
            b.expect_object(kBodyKeys);
            sim::BodyDesc d;
            read_common(b, materials, d);
            read_rigid_body(b, scene, d);
            d.position = b.at("position").vec3();
            if (b.has("velocity")) d.velocity = b.at("velocity").vec3();
            if (b.has("player")) {
                d.player = static_cast<int>(b.at("player").integer(0, 63));
                if (d.mass.raw == 0) b.at("mass").fail("a player body must have mass > 0");
            }
            scene.bodies.push_back(d);
        }
    }
    if (r.has("spawners")) {
        const Reader spawners = r.at("spawners");
        for (std::size_t i = 0; i < spawners.array_size(); ++i) {
            const Reader s = spawners.at(i);
            s.expect_object(kSpawnerKeys);
            sim::SpawnerDesc d;
            read_common(s, materials, d);
            for (const char* key : {"friction", "static_friction"})
                if (s.has(key) && !scene.rigid.enabled) s.at(key).fail("needs a rigid scene (top-level \"rigid\")");
            d.count = static_cast<int>(s.at("count").integer(0, 1000000));
            check_total(s.at("count"), static_cast<std::size_t>(d.count));
            const Reader region = s.at("region");
            region.expect_object({"min", "max"});
            d.region_min = region.at("min").vec3();
            d.region_max = region.at("max").vec3();
            if (!(d.region_min.x < d.region_max.x && d.region_min.y < d.region_max.y && d.region_min.z < d.region_max.z))
                region.fail("min must be below max on every axis");
            if (s.has("max_speed")) d.max_speed = s.at("max_speed").fixed_in("0", "10000");
            if (s.has("seed")) d.seed = s.at("seed").seed();
            sim::expand_spawner(scene, d);
        }
    }
    if (const std::string err = sim::validate(scene); !err.empty()) r.fail(err);
    return scene;
}

std::string read_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(path.string() + ": cannot open scene file");
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) throw SceneError(path.string() + ": read error");
    return ss.str();
}
}  // namespace

namespace {
std::size_t g_max_scene_bodies = kDefaultMaxSceneBodies;
}  // namespace

void set_max_scene_bodies(std::size_t n) { g_max_scene_bodies = n; }
std::size_t max_scene_bodies() { return g_max_scene_bodies; }

sim::SceneDesc parse_scene(const std::string& text, const std::string& origin) {
    json root;
    DecimalSax sax(root, /*allow_exceptions=*/false);
    bool ok = false;
    try {
        ok = json::sax_parse(text, &sax);
    } catch (const json::exception& e) {
        throw SceneError(origin + ": " + e.what());
    }
    if (!ok || sax.is_errored()) {
        if (sax.error_is_number)  // the offset is just past the number
            throw SceneError(origin + ": " + line_column(text, sax.error_position - sax.error_token.size()) +
                             ": number " + sax.error_token +
                             " is outside the Q32.32 range (|x| < 2147483648)");
        if (!sax.error_what.empty()) throw SceneError(origin + ": " + sax.error_what);
        throw SceneError(origin + ": malformed JSON");
    }
    try {
        return read_scene(Reader(root, origin, ""));
    } catch (const json::exception& e) {  // a required key is missing, for example
        throw SceneError(origin + ": " + e.what());
    }
}

sim::SceneDesc load_scene_file(const std::filesystem::path& path) {
    sim::SceneDesc scene = parse_scene(read_file(path), path.string());
    if (scene.name.empty()) scene.name = path.stem().string();
    return scene;
}

std::filesystem::path resolve_scene(const std::string& name) {
    namespace fs = std::filesystem;
    if (fs::is_regular_file(name)) return name;
    std::vector<fs::path> dirs;
    if (const char* env = std::getenv("LOCKROLL_SCENE_DIR")) dirs.emplace_back(env);
#ifdef LOCKROLL_SOURCE_SCENE_DIR
    dirs.emplace_back(LOCKROLL_SOURCE_SCENE_DIR);
#endif
#ifdef LOCKROLL_INSTALL_SCENE_DIR
    dirs.emplace_back(LOCKROLL_INSTALL_SCENE_DIR);
#endif
    for (const auto& d : dirs) {
        const fs::path p = d / (name + ".json");
        if (fs::is_regular_file(p)) return p;
    }
    throw SceneError(name + ": no such scene file, and no shipped scene of that name (try paper, bodies_1k, bodies_10k)");
}

sim::SceneDesc load_scene(const std::string& name_or_path) { return load_scene_file(resolve_scene(name_or_path)); }

}  // namespace lockroll::harness
