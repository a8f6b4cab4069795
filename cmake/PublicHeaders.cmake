# The installed surface, in this one place: which headers each public library lockroll_<name>
# installs. Each is installed as <prefix>/include/lockroll/<dir>/<header> (one level: the source
# folder's name; cmake/Install.cmake), the build tree gives the same spelling through per-file
# links in <build>/include/lockroll/, and only <prefix>/include (<build>/include) is an include
# dir, so a game's own net/clock.h can never stand in for ours. An installed header includes the
# others only as <lockroll/<dir>/<header>>; internal code keeps "rollback/session.h".
#
# Two lists per library:
#  - LOCKROLL_SURFACE_<name>: the API a game programs against (docs/guide.md).
#  - LOCKROLL_DETAIL_<name>: not API, installed only because a surface header still includes it
#    (a member, base or argument type no pimpl hides yet). Each entry goes when its includer is
#    pimpl'd; nothing may be added here without an includer in the surface.
# Besides these: <lockroll/version.h> (generated) and <lockroll/lockroll.h> (the C ABI, capi/).
# 16 surface headers (sim 4, rollback 8, transport 2, net 2), 18 installed in all: issue 23 asks
# for a small, deliberate surface, so a new header here is a decision (a new concept for a game),
# not a side effect of splitting a file.
# tests/install lists what must be installed and fails on one header more; tests/headers compiles
# each alone.
set(LOCKROLL_HEADER_DIR_sim sim)
# The public part of the physics world, one header per concept: the number (fixed.h, with the
# 128-bit integer layer Fixed's inline arithmetic runs on), the vector math (vec3.h: Vec3 and a
# body's orientation, Quat and Mat3), the scene as data (scene.h) and the world that steps it
# (world.h, with World::step's PlayerInput).
set(LOCKROLL_SURFACE_sim fixed.h vec3.h scene.h world.h)
set(LOCKROLL_DETAIL_sim)

set(LOCKROLL_HEADER_DIR_rollback rollback)
# The sessions are facades over in-tree state machines (session_impl.h, relay_session_impl.h), so
# what they name is only what a game sees. One header per concept: the game's contract
# (simulation.h) and the World's adapter (world_simulation.h); the P2P session with its config and
# the queries both sessions answer (session.h); the relay session (relay_session.h); the sync test
# (sync_test.h); the events and observer callbacks (events.h); the per-tick values, ids and stats
# both sessions share (session_types.h); replays (replay.h).
set(LOCKROLL_SURFACE_rollback simulation.h world_simulation.h session.h relay_session.h sync_test.h
    events.h session_types.h replay.h)
set(LOCKROLL_DETAIL_rollback)

set(LOCKROLL_HEADER_DIR_transport transport)
set(LOCKROLL_SURFACE_transport transport.h enet_transport.h)
set(LOCKROLL_DETAIL_transport)

set(LOCKROLL_HEADER_DIR_net net)
# update_result.h: what NetSession::update() returns and its observer hears; the runners and the
# clock (peer_runner.h, clock.h) stay in-tree.
set(LOCKROLL_SURFACE_net session_builder.h update_result.h)
set(LOCKROLL_DETAIL_net)

# lockroll_public_headers(name dir_var headers_var): the directory under include/lockroll/ and the
# headers (file names in it) lockroll_<name> installs. Without ENet (WebAssembly) the ENet
# transport is not built and its header not installed.
function(lockroll_public_headers name dir_var headers_var)
  if(NOT DEFINED LOCKROLL_HEADER_DIR_${name})
    message(FATAL_ERROR "cmake/PublicHeaders.cmake: public library ${name} lists no headers")
  endif()
  set(headers ${LOCKROLL_SURFACE_${name}} ${LOCKROLL_DETAIL_${name}})
  if(name STREQUAL "transport" AND NOT LOCKROLL_ENET)
    list(REMOVE_ITEM headers enet_transport.h)
  endif()
  set(${dir_var} ${LOCKROLL_HEADER_DIR_${name}} PARENT_SCOPE)
  set(${headers_var} ${headers} PARENT_SCOPE)
endfunction()
