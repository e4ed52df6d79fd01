# Man pages and bash completions, written by the programs themselves from their options
# (the settings table's, tools/common/cli_docs.hpp) and the daemon's table of configuration
# keys: `hdrd docs man|config-man|bash-completion`, `hdrctl docs man|bash-completion`.
# Target hdrd_docs (in `all`); installed by cmake/Install.cmake; checked by tests/package.
set(HDRD_DOCS_DIR ${PROJECT_BINARY_DIR}/generated-docs)
file(MAKE_DIRECTORY ${HDRD_DOCS_DIR})
set(_hdrd_docs)
foreach(_spec "hdrd|man|hdrd.1" "hdrd|config-man|hdrd.toml.5" "hdrd|bash-completion|hdrd.bash"
              "hdrctl|man|hdrctl.1" "hdrctl|bash-completion|hdrctl.bash")
  string(REPLACE "|" ";" _spec "${_spec}")
  list(GET _spec 0 _prog)
  list(GET _spec 1 _what)
  list(GET _spec 2 _out)
  set(_extra)
  set(_deps ${_prog})
  if(_what STREQUAL "config-man")
    set(_extra --config-file ${PROJECT_SOURCE_DIR}/config/hdrd.toml)
    list(APPEND _deps ${PROJECT_SOURCE_DIR}/config/hdrd.toml)
  endif()
  add_custom_command(OUTPUT ${HDRD_DOCS_DIR}/${_out}
    COMMAND $<TARGET_FILE:${_prog}> docs ${_what} ${_extra} > ${_out}.tmp
    COMMAND ${CMAKE_COMMAND} -E rename ${_out}.tmp ${_out}
    DEPENDS ${_deps}
    WORKING_DIRECTORY ${HDRD_DOCS_DIR}
    COMMENT "Writing ${_out} (${_prog} docs ${_what})")
  list(APPEND _hdrd_docs ${HDRD_DOCS_DIR}/${_out})
endforeach()
add_custom_target(hdrd_docs ALL DEPENDS ${_hdrd_docs})
