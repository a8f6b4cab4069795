# Every dependency is a Debian package; a missing one stops configuration with the package name.
include(FindPkgConfig)

macro(lockroll_require found debian_pkg what)
  if(NOT ${found})
    message(FATAL_ERROR "lockroll needs ${what}: install the Debian package '${debian_pkg}' "
                        "(apt-get install ${debian_pkg}), or run scripts/install-deps.sh")
  endif()
endmacro()

# xxHash: used header-only (XXH_INLINE_ALL) so the sim core cross-compiles with no library.
find_path(XXHASH_INCLUDE_DIR xxhash.h)
lockroll_require(XXHASH_INCLUDE_DIR libxxhash-dev "xxHash headers")

# nlohmann-json: header-only, compiled into lockroll_match's scene loader (found as a path, like
# xxHash, so the installed package does not depend on it, and a WebAssembly build finds it too).
if(NOT LOCKROLL_SIM_ONLY)
  find_path(NLOHMANN_JSON_INCLUDE_DIR nlohmann/json.hpp)
  lockroll_require(NLOHMANN_JSON_INCLUDE_DIR nlohmann-json3-dev "nlohmann-json headers")
endif()

if(NOT LOCKROLL_SIM_ONLY AND LOCKROLL_ENET)
  find_package(PkgConfig QUIET)
  lockroll_require(PKG_CONFIG_FOUND pkg-config "pkg-config")
  pkg_check_modules(ENET QUIET IMPORTED_TARGET libenet)
  lockroll_require(ENET_FOUND libenet-dev "ENet")
  # The relay server's connect tokens (server/connect_token.h): sealed and opened by libsodium.
  pkg_check_modules(SODIUM QUIET IMPORTED_TARGET libsodium)
  lockroll_require(SODIUM_FOUND libsodium-dev "libsodium")
  # lockroll-server's allocator (server/CMakeLists.txt), optional: ENet allocates a packet and a
  # command per datagram, and mimalloc's malloc / free cost a third of glibc's (docs/performance.md,
  # "Density"). Not one of the project's chosen dependencies, so the server builds and behaves the
  # same without it (glibc's malloc), only dearer per datagram; install-deps.sh installs it.
  find_package(mimalloc CONFIG QUIET)
  if(mimalloc_FOUND)
    message(STATUS "lockroll-server allocates with mimalloc")
  else()
    message(STATUS "lockroll-server allocates with the C library's malloc (libmimalloc-dev not found: optional)")
  endif()
  find_package(spdlog QUIET)
  lockroll_require(spdlog_FOUND libspdlog-dev "spdlog")
  find_package(nlohmann_json 3.10 QUIET)
  lockroll_require(nlohmann_json_FOUND nlohmann-json3-dev "nlohmann-json")
  find_package(CLI11 QUIET)
  lockroll_require(CLI11_FOUND libcli11-dev "CLI11")
  if(LOCKROLL_BUILD_TESTS)
    find_package(GTest QUIET)
    lockroll_require(GTest_FOUND libgtest-dev "GoogleTest")
  endif()
  if(LOCKROLL_BUILD_BENCH)
    find_package(benchmark QUIET)
    lockroll_require(benchmark_FOUND libbenchmark-dev "Google Benchmark")
  endif()
endif()
