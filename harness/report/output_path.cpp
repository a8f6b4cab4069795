#include "harness/report/output_path.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include <unistd.h>

#include "harness/match/cli_error.h"

namespace lockroll::harness {

namespace {
namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& flag, const std::string& path, const std::string& what) {
    throw UsageError(flag + " " + (path.empty() ? "\"\"" : path) + ": " + what);
}

// Whether a file can be created in `dir`: create one with a unique name and remove it. Asking
// access(2) is not enough: it says yes for read-only mounts and for /proc as root.
std::string probe_create(const fs::path& dir) {
    std::string name = (dir / ".lockroll-probe-XXXXXX").string();
    const int fd = ::mkstemp(name.data());
    if (fd < 0) return std::strerror(errno);
    ::close(fd);
    ::unlink(name.c_str());
    return {};
}

fs::path parent_or_dot(const fs::path& p) {
    const fs::path parent = p.parent_path();
    return parent.empty() ? fs::path(".") : parent;
}
}  // namespace

void check_output_file(const std::string& flag, const std::string& path) {
    if (path.empty()) fail(flag, path, "empty path");
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (fs::is_directory(st)) fail(flag, path, "is a directory, expected a file name");
    if (fs::exists(st) && !fs::is_regular_file(st)) fail(flag, path, "exists and is not a regular file");
    const fs::path dir = parent_or_dot(path);
    if (!fs::is_directory(dir, ec)) fail(flag, path, "directory " + dir.string() + " does not exist");
    if (const std::string why = probe_create(dir); !why.empty())
        fail(flag, path, "cannot create files in " + dir.string() + ": " + why);
}

void check_output_dir(const std::string& flag, const std::string& path) {
    if (path.empty()) fail(flag, path, "empty path");
    std::error_code ec;
    fs::path at = path;
    // The nearest existing ancestor is where create_directories will start.
    while (!fs::exists(fs::symlink_status(at, ec))) {
        const fs::path up = parent_or_dot(at);
        if (up == at) break;
        at = up;
    }
    if (!fs::is_directory(at, ec)) {
        if (at == fs::path(path)) fail(flag, path, "exists and is not a directory");
        fail(flag, path, at.string() + " is not a directory");
    }
    if (const std::string why = probe_create(at); !why.empty())
        fail(flag, path, "cannot create files in " + at.string() + ": " + why);
}

}  // namespace lockroll::harness
