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
# tests/install lists what must be installed and fails on one header more; tests/headers compiles
# each alone.
set(LOCKROLL_HEADER_DIR_sim sim)
# wide_int.h, quat.h and input.h are API too, not leftovers: Fixed's arithmetic is inline over
# wide_int.h's 128-bit type (a Q32.32 product needs it, and inline is what keeps the step fast),
# a scene's bodies carry an orientation (quat.h's Quat), and World::step takes the players'
# PlayerInput (input.h).
set(LOCKROLL_SURFACE_sim fixed.h vec3.h scene.h world.h wide_int.h quat.h input.h)
set(LOCKROLL_DETAIL_sim)

set(LOCKROLL_HEADER_DIR_rollback rollback)
# The sessions are facades over in-tree state machines (session_impl.h, relay_session_impl.h), so
# what they name is only what a game sees: configs, stats, events, ids, the per-tick values.
set(LOCKROLL_SURFACE_rollback simulation.h world_simulation.h session.h relay_session.h sync_test.h
    session_event.h replay.h session_config.h session_types.h session_queries.h player_id.h events.h telemetry.h)
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
