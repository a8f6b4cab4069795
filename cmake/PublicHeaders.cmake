# Which headers a public library lockroll_<name> installs, and under which directory:
# <dir> is the target's LOCKROLL_HEADER_DIR property, else <name> (a library built from <name>/);
# the headers are its LOCKROLL_HEADERS property (file names in <dir>), else every <dir>/*.h.
# They are installed as <lockroll/<dir>/<header>> (cmake/Install.cmake) and each compiles alone
# (tests/headers).
function(lockroll_public_headers name dir_var headers_var)
  get_target_property(dir lockroll_${name} LOCKROLL_HEADER_DIR)
  if(NOT dir)
    set(dir ${name})
  endif()
  get_target_property(headers lockroll_${name} LOCKROLL_HEADERS)
  if(NOT headers)
    file(GLOB headers CONFIGURE_DEPENDS RELATIVE ${PROJECT_SOURCE_DIR}/${dir} ${PROJECT_SOURCE_DIR}/${dir}/*.h)
  endif()
  set(${dir_var} ${dir} PARENT_SCOPE)
  set(${headers_var} ${headers} PARENT_SCOPE)
endfunction()
