# Install rules: `cmake --install build --prefix /usr` (DESTDIR= works) lays hdrd out as a
# system service (README "Install"); the Debian package (debian/) is this tree. The paths
# in the systemd unit and the place of hdrd.toml follow the prefix given at install time
# (--prefix), not only the configured one: both are written by cmake/install_paths.cmake
# when the install runs.
include(GNUInstallDirs)

set(HDRD_SYSTEMD_UNITDIR "lib/systemd/system" CACHE STRING "systemd system units (relative: to the prefix)")
set(HDRD_SYSUSERSDIR "lib/sysusers.d" CACHE STRING "sysusers.d files (relative: to the prefix)")
set(HDRD_TMPFILESDIR "lib/tmpfiles.d" CACHE STRING "tmpfiles.d files (relative: to the prefix)")
set(HDRD_PYTHONDIR "lib/python3/dist-packages" CACHE STRING "where the Python client module goes (relative: to the prefix)")
set(HDRD_BASH_COMPLETIONDIR "${CMAKE_INSTALL_DATAROOTDIR}/bash-completion/completions" CACHE STRING
    "bash completions (relative: to the prefix)")

install(TARGETS hdrd hdrctl RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The installed programs are linked with full RELRO (a daemon's GOT read-only); only these
# two, so that the flag costs two links, not the test programs'.
target_link_options(hdrd PRIVATE LINKER:-z,relro,-z,now)
target_link_options(hdrctl PRIVATE LINKER:-z,relro,-z,now)

install(CODE "
  set(HDRD_SOURCE_DIR \"${PROJECT_SOURCE_DIR}\")
  set(HDRD_BINARY_DIR \"${PROJECT_BINARY_DIR}\")
  set(HDRD_BINDIR \"${CMAKE_INSTALL_BINDIR}\")
  set(HDRD_DOCDIR \"${CMAKE_INSTALL_DOCDIR}\")
  set(HDRD_SYSCONFDIR \"${CMAKE_INSTALL_SYSCONFDIR}\")
  set(HDRD_SYSTEMD_UNITDIR \"${HDRD_SYSTEMD_UNITDIR}\")
  include(\"${PROJECT_SOURCE_DIR}/cmake/install_paths.cmake\")")
install(FILES config/hdrd.socket DESTINATION ${HDRD_SYSTEMD_UNITDIR})
install(FILES config/hdrd.sysusers.conf DESTINATION ${HDRD_SYSUSERSDIR} RENAME hdrd.conf)
install(FILES config/hdrd.tmpfiles.conf DESTINATION ${HDRD_TMPFILESDIR} RENAME hdrd.conf)
install(DIRECTORY config/profiles/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples/profiles)
install(FILES config/hdrd.toml DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples RENAME hdrd.toml.defaults)
install(FILES README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(DIRECTORY docs DESTINATION ${CMAKE_INSTALL_DOCDIR})  # README.md's links (docs/...) hold there too
install(FILES ${HDRD_DOCS_DIR}/hdrd.1 ${HDRD_DOCS_DIR}/hdrctl.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
install(FILES ${HDRD_DOCS_DIR}/hdrd.toml.5 DESTINATION ${CMAKE_INSTALL_MANDIR}/man5)
install(FILES ${HDRD_DOCS_DIR}/hdrd.bash DESTINATION ${HDRD_BASH_COMPLETIONDIR} RENAME hdrd)
install(FILES ${HDRD_DOCS_DIR}/hdrctl.bash DESTINATION ${HDRD_BASH_COMPLETIONDIR} RENAME hdrctl)
install(FILES clients/python/hdrd_client.py DESTINATION ${HDRD_PYTHONDIR})
install(FILES clients/python/example.py DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples/python)
