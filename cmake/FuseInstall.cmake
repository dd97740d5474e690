# Installation of the vehicle deployment (component "runtime"); the Debian packages are built from
# it by debhelper (debian/, docs/packaging.md).
#
#   cmake --install BUILD --prefix /usr       binaries, systemd units, sysusers.d / sysctl.d
#                                             drop-ins, a udev rule, the config under
#                                             /etc/fuse-slam (component "query": the planner client)
#
# Every name a user sees is "fuse-slam" (Debian's "fuse" is the filesystem): /etc/fuse-slam,
# /var/lib/fuse-slam, the user _fuse-slam, fuse-slam.target and fuse-slam-*.service; the binaries
# keep their fuse-* names, which no Debian package uses.
# Paths follow GNUInstallDirs; units, sysusers.d, sysctl.d and udev rules go to lib/... under the
# prefix (systemd reads /usr/lib and /usr/local/lib; debian/rules moves units and the udev rule
# to /lib, where Debian 12 keeps them). The config goes to /etc/fuse-slam for the /usr prefix, PREFIX/etc/fuse-slam otherwise. The units name
# the binaries and the config by absolute path, so they are written at install time from the
# prefix in force then.
include(GNUInstallDirs)

set(FUSE_DEPLOY_DIR ${PROJECT_SOURCE_DIR}/deploy)
set(FUSE_UNITS fuse-slam-map.service fuse-slam-state.service fuse-slam-update.service fuse-slam-ingest.service
               fuse-slam-viz.service)

# ---- binaries: the four services, the live view and the operator tools ---------------------------------
install(TARGETS fuse-map fuse-state fuse-update fuse-ingest fuse-viz
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
install(TARGETS fuse-launch fuse-map-ctl fuse-keystore fuse-map-export fuse-record fuse-run fuse-eval fuse-sim fuse-import
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
install(FILES ${PROJECT_SOURCE_DIR}/config/mid360.yaml ${PROJECT_SOURCE_DIR}/config/spinning.yaml
  DESTINATION ${CMAKE_INSTALL_DATADIR}/fuse-slam/config COMPONENT runtime)

# ---- units and config: written at install time -------------------------------------------
set(FUSE_UNIT_STAGE ${CMAKE_BINARY_DIR}/deploy)
install(CODE "
  if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
    set(FUSE_CONFIG_DIR /etc/fuse-slam)
  else()
    set(FUSE_CONFIG_DIR \"\${CMAKE_INSTALL_PREFIX}/etc/fuse-slam\")
  endif()
  set(FUSE_CONFIG_FILE \"\${FUSE_CONFIG_DIR}/fuse-slam.yaml\")
  set(FUSE_UNIT_DIR \"\${CMAKE_INSTALL_PREFIX}/lib/systemd/system\")
  set(FUSE_UDEV_DIR \"\${CMAKE_INSTALL_PREFIX}/lib/udev/rules.d\")
  set(FUSE_BINDIR \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}\")
  foreach(unit ${FUSE_UNITS})
    configure_file(\"${FUSE_DEPLOY_DIR}/\${unit}.in\" \"${FUSE_UNIT_STAGE}/\${unit}\" @ONLY)
  endforeach()
  file(INSTALL DESTINATION \"\${FUSE_UNIT_DIR}\" TYPE FILE
       FILES \"${FUSE_DEPLOY_DIR}/fuse-slam.target\")
  foreach(unit ${FUSE_UNITS})
    file(INSTALL DESTINATION \"\${FUSE_UNIT_DIR}\" TYPE FILE
         FILES \"${FUSE_UNIT_STAGE}/\${unit}\")
  endforeach()
  file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/lib/sysusers.d\" TYPE FILE
       RENAME fuse-slam.conf FILES \"${FUSE_DEPLOY_DIR}/fuse-slam.sysusers\")
  file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/lib/sysctl.d\" TYPE FILE
       RENAME 60-fuse-slam-dds.conf FILES \"${FUSE_DEPLOY_DIR}/fuse-slam-dds.sysctl\")
  file(INSTALL DESTINATION \"\${FUSE_UDEV_DIR}\" TYPE FILE
       RENAME 60-fuse-slam-cpu-latency.rules FILES \"${FUSE_DEPLOY_DIR}/fuse-slam-cpu-latency.rules\")
  # The installed config: mid360.yaml with the bus secured (deploy/fuse-slam-security.yaml.in).
  file(READ \"${PROJECT_SOURCE_DIR}/config/mid360.yaml\" FUSE_BASE_CONFIG)
  configure_file(\"${FUSE_DEPLOY_DIR}/fuse-slam-security.yaml.in\" \"${FUSE_UNIT_STAGE}/security.yaml\" @ONLY)
  file(READ \"${FUSE_UNIT_STAGE}/security.yaml\" FUSE_SECURITY_CONFIG)
  file(WRITE \"${FUSE_UNIT_STAGE}/fuse-slam.yaml\" \"\${FUSE_BASE_CONFIG}\${FUSE_SECURITY_CONFIG}\")
  file(INSTALL DESTINATION \"\${FUSE_CONFIG_DIR}\" TYPE FILE FILES \"${FUSE_UNIT_STAGE}/fuse-slam.yaml\")
  file(INSTALL DESTINATION \"\${FUSE_CONFIG_DIR}\" TYPE FILE FILES \"${FUSE_DEPLOY_DIR}/ingest.env\")
" COMPONENT runtime)

# `make install` / `cmake --install` install what has been built instead of first building every
# target of the tree (tests and benchmarks included): build, then install.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
