# Runs at install time (cmake/Install.cmake): writes what depends on the prefix the install
# uses, which `cmake --install --prefix P` may change after configuring.
#  - hdrd.service from config/hdrd.service.in, with the installed program and config paths;
#  - hdrd.toml from config/hdrd.toml (every key, documented) with what a system service
#    needs: the socket in /run/hdrd for the hdrd group, dumps in /var/lib/hdrd/dumps.
# file(INSTALL) puts both under $DESTDIR, as install(FILES) would.

# GNUInstallDirs' rule for the configuration directory: /etc for the prefix /usr (and /),
# PREFIX/etc otherwise.
if(IS_ABSOLUTE "${HDRD_SYSCONFDIR}")
  set(_etc "${HDRD_SYSCONFDIR}")
elseif(CMAKE_INSTALL_PREFIX MATCHES "^/(usr/?)?$")
  set(_etc "/${HDRD_SYSCONFDIR}")
else()
  set(_etc "${CMAKE_INSTALL_PREFIX}/${HDRD_SYSCONFDIR}")
endif()
function(_hdrd_full out dir)
  if(IS_ABSOLUTE "${dir}")
    set(${out} "${dir}" PARENT_SCOPE)
  else()
    string(REGEX REPLACE "/$" "" _p "${CMAKE_INSTALL_PREFIX}")
    set(${out} "${_p}/${dir}" PARENT_SCOPE)
  endif()
endfunction()
_hdrd_full(CMAKE_INSTALL_FULL_BINDIR "${HDRD_BINDIR}")
_hdrd_full(CMAKE_INSTALL_FULL_DOCDIR "${HDRD_DOCDIR}")
_hdrd_full(_unitdir "${HDRD_SYSTEMD_UNITDIR}")
set(CMAKE_INSTALL_FULL_SYSCONFDIR "${_etc}")
set(HDRD_GENERATED_NOTE "Written from config/hdrd.service.in by the install (cmake/install_paths.cmake).")

set(_stage "${HDRD_BINARY_DIR}/install-stage")
file(MAKE_DIRECTORY "${_stage}")
configure_file("${HDRD_SOURCE_DIR}/config/hdrd.service.in" "${_stage}/hdrd.service" @ONLY)

file(READ "${HDRD_SOURCE_DIR}/config/hdrd.toml" _toml)
foreach(_pair
    "socket_path = \"\"|socket_path = \"/run/hdrd/hdrd.sock\""
    "socket_group = \"\"|socket_group = \"hdrd\""
    "dump_dir = \"\"|dump_dir = \"/var/lib/hdrd/dumps\"")
  string(REPLACE "|" ";" _pair "${_pair}")
  list(GET _pair 0 _from)
  list(GET _pair 1 _to)
  string(FIND "${_toml}" "\n${_from}\n" _at)
  if(_at EQUAL -1)
    message(FATAL_ERROR "config/hdrd.toml has no line '${_from}' for the installed hdrd.toml (cmake/install_paths.cmake)")
  endif()
  string(REPLACE "\n${_from}\n" "\n# Installed value (the built-in default: ${_from}).\n${_to}\n" _toml "${_toml}")
endforeach()
file(WRITE "${_stage}/hdrd.toml" "${_toml}")

file(INSTALL DESTINATION "${_unitdir}" TYPE FILE PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ
     FILES "${_stage}/hdrd.service")
file(INSTALL DESTINATION "${_etc}/hdrd" TYPE FILE PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ
     FILES "${_stage}/hdrd.toml")
