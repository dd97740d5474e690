# Installation of the vehicle deployment (component "runtime") and the .deb (CPack).
#
#   cmake --install BUILD --prefix /usr       binaries, systemd units, sysusers.d / sysctl.d
#                                             drop-ins, a udev rule, the config under /etc/fuse
#   cpack --config BUILD/CPackConfig.cmake    fuse_<version>_<arch>.deb (all components,
#                                             including "query", the planner client library)
#
# Paths follow GNUInstallDirs; units, sysusers.d, sysctl.d and udev rules go to lib/... under the prefix
# (systemd reads /usr/lib and /usr/local/lib). The config goes to /etc/fuse for the /usr prefix,
# PREFIX/etc/fuse otherwise. The units name the binaries and the config by absolute path, so they
# are written at install time from the prefix in force then (cpack installs with prefix /usr into
# a staging DESTDIR: CPACK_SET_DESTDIR).
include(GNUInstallDirs)

set(FUSE_DEPLOY_DIR ${PROJECT_SOURCE_DIR}/deploy)
set(FUSE_UNITS fuse-map.service fuse-state.service fuse-update.service fuse-ingest.service)

# ---- binaries: the four services and the operator tools ---------------------------------
install(TARGETS fuse-map fuse-state fuse-update fuse-ingest
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
install(TARGETS fuse-launch fuse-map-ctl fuse-map-export fuse-record fuse-run fuse-eval fuse-sim
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
install(FILES ${PROJECT_SOURCE_DIR}/config/mid360.yaml ${PROJECT_SOURCE_DIR}/config/spinning.yaml
  DESTINATION ${CMAKE_INSTALL_DATADIR}/fuse/config COMPONENT runtime)

# ---- units and config: written at install time -------------------------------------------
set(FUSE_UNIT_STAGE ${CMAKE_BINARY_DIR}/deploy)
install(CODE "
  if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
    set(FUSE_CONFIG_DIR /etc/fuse)
  else()
    set(FUSE_CONFIG_DIR \"\${CMAKE_INSTALL_PREFIX}/etc/fuse\")
  endif()
  set(FUSE_CONFIG_FILE \"\${FUSE_CONFIG_DIR}/fuse.yaml\")
  set(FUSE_BINDIR \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}\")
  foreach(unit ${FUSE_UNITS})
    configure_file(\"${FUSE_DEPLOY_DIR}/\${unit}.in\" \"${FUSE_UNIT_STAGE}/\${unit}\" @ONLY)
  endforeach()
  file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/lib/systemd/system\" TYPE FILE
       FILES \"${FUSE_DEPLOY_DIR}/fuse.target\")
  foreach(unit ${FUSE_UNITS})
    file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/lib/systemd/system\" TYPE FILE
         FILES \"${FUSE_UNIT_STAGE}/\${unit}\")
  endforeach()
  file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/lib/sysusers.d\" TYPE FILE
       RENAME fuse.conf FILES \"${FUSE_DEPLOY_DIR}/fuse.sysusers\")
  file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/lib/sysctl.d\" TYPE FILE
       RENAME 60-fuse-dds.conf FILES \"${FUSE_DEPLOY_DIR}/fuse-dds.sysctl\")
  file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/lib/udev/rules.d\" TYPE FILE
       RENAME 60-fuse-cpu-latency.rules FILES \"${FUSE_DEPLOY_DIR}/fuse-cpu-latency.rules\")
  file(INSTALL DESTINATION \"\${FUSE_CONFIG_DIR}\" TYPE FILE
       RENAME fuse.yaml FILES \"${PROJECT_SOURCE_DIR}/config/mid360.yaml\")
  file(INSTALL DESTINATION \"\${FUSE_CONFIG_DIR}\" TYPE FILE FILES \"${FUSE_DEPLOY_DIR}/ingest.env\")
" COMPONENT runtime)

# ---- the .deb ------------------------------------------------------------------------------
# cpack (and `make install`) package what has been built instead of first building every target
# of the tree (tests and benchmarks included); build, then package.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME fuse)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "FUSE")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "FUSE LiDAR-inertial state estimation: services, tools, systemd units, query client")
set(CPACK_PACKAGE_CONTACT "FUSE maintainers")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_SET_DESTDIR ON)  # install with prefix /usr into the staging root (the units name /usr/bin)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_PACKAGE_NAME fuse)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)  # runtime Debian packages from the binaries' libraries
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "systemd, fastdds-tools")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
  ${FUSE_DEPLOY_DIR}/debian/postinst ${FUSE_DEPLOY_DIR}/debian/prerm ${FUSE_DEPLOY_DIR}/debian/postrm
  ${FUSE_DEPLOY_DIR}/debian/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
