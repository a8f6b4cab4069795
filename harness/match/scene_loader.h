// Scene files: JSON (docs/scene-format.md) to sim::SceneDesc.
//
// Numbers are taken from their decimal text straight to Q32.32 (never through double), so a
// scene means the same bits everywhere. Errors name the file, the place (a JSON pointer such as
// /bodies/3/radius, or line and column for syntax) and the problem; nothing is half-loaded: the
// loader either returns a complete, validated scene or throws SceneError.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

#include <lockroll/sim/scene.h>

namespace lockroll::harness {

struct SceneError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Most bodies a scene may describe (room walls, bodies and spawned bodies together), checked
// before anything is expanded, so a few bytes of scene cannot ask for unbounded memory and
// time. The lockroll program sets it from --max-bodies; it holds for the whole process.
inline constexpr std::size_t kDefaultMaxSceneBodies = 1000000;
void set_max_scene_bodies(std::size_t n);
std::size_t max_scene_bodies();

// `origin` names the text in messages (usually the file path).
sim::SceneDesc parse_scene(const std::string& json_text, const std::string& origin);
sim::SceneDesc load_scene_file(const std::filesystem::path& path);

// A path to an existing file, or the name of a shipped scene ("paper", "bodies_1k", ...),
// searched in $LOCKROLL_SCENE_DIR, the source tree's harness/scenes and the installed share dir.
std::filesystem::path resolve_scene(const std::string& name_or_path);

// resolve_scene + load_scene_file.
sim::SceneDesc load_scene(const std::string& name_or_path);

}  // namespace lockroll::harness
