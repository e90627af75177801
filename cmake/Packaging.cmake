# Installation rules and Debian packages (CPack DEB), one package per component:
#   wheeljump-common          models (URDF + actuator table), the profile switch wheeljump-profile,
#                             the jump executor's gains (config/jump_executor.yaml) per profile
#   wheeljump-planner-server  planner_server, planner_cli, their profiles, the systemd unit
#   wheeljump-robot-client    robot_client (when that target is built), its profiles, the unit
# Build them with `cpack -G DEB` in the build folder, or `bash deploy/build-debs.sh`.
# The layout is fixed by the units: binaries in /usr/bin, models in /usr/share/wheeljump/models,
# configuration in /etc/wheeljump (conffiles), units in /lib/systemd/system.
# Binaries find the models beside themselves (<exe>/../share/wheeljump/models, see
# RobotModel::defaultModelsDir), so an installed tree works wherever it is unpacked.
include(GNUInstallDirs)

set(WJ_DEPLOY_DIR ${PROJECT_SOURCE_DIR}/deploy)
set(WJ_ETC_DIR /etc/wheeljump)
set(WJ_UNIT_DIR /lib/systemd/system)
set(WJ_PROFILES nuc workstation)
set(WJ_DEB_CONTROL_DIR ${PROJECT_BINARY_DIR}/deb-control)

# Conffiles of each component, collected while the rules are declared.
set(WJ_CONFFILES_common "")
set(WJ_CONFFILES_planner_server "")
set(WJ_CONFFILES_robot_client "")

# wj_install_conffile(<component> <source> <destination folder> [RENAME <name>])
function(wj_install_conffile component source destination)
  cmake_parse_arguments(ARG "" "RENAME" "" ${ARGN})
  get_filename_component(name ${source} NAME)
  if(ARG_RENAME)
    set(name ${ARG_RENAME})
  endif()
  install(FILES ${source} DESTINATION ${destination} RENAME ${name} COMPONENT ${component})
  set(list ${WJ_CONFFILES_${component}})
  list(APPEND list ${destination}/${name})
  set(WJ_CONFFILES_${component} ${list} PARENT_SCOPE)
endfunction()

# --- wheeljump-common
install(FILES ${WJ_MODELS_DIR}/wheeljump.urdf ${WJ_MODELS_DIR}/actuators.yaml
              ${WJ_MODELS_DIR}/actuators-57nm.yaml
        DESTINATION ${CMAKE_INSTALL_DATADIR}/wheeljump/models COMPONENT common)
install(PROGRAMS ${WJ_DEPLOY_DIR}/wheeljump-profile DESTINATION ${CMAKE_INSTALL_BINDIR}
        COMPONENT common)
install(FILES ${WJ_DEPLOY_DIR}/systemd/wheeljump-planner-tls.conf
        DESTINATION ${CMAKE_INSTALL_DATADIR}/wheeljump/systemd COMPONENT common)
foreach(profile ${WJ_PROFILES})
  install(DIRECTORY DESTINATION ${WJ_ETC_DIR}/profiles/${profile} COMPONENT common)
  # The jump executor's gains, read by the robot client (its executor) and by the service's
  # verifier (the executor it simulates): one file for both, the same in every profile.
  wj_install_conffile(common ${WJ_CONFIG_DIR}/jump_executor.yaml ${WJ_ETC_DIR}/profiles/${profile})
endforeach()

# --- wheeljump-planner-server
if(TARGET planner_server)
  install(TARGETS planner_server planner_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
          COMPONENT planner_server)
  foreach(profile ${WJ_PROFILES})
    wj_install_conffile(planner_server ${WJ_DEPLOY_DIR}/profiles/${profile}/planner_server.yaml
                        ${WJ_ETC_DIR}/profiles/${profile})
    # Its planner settings (settings_file: a path beside it), the same in every profile: the
    # profiles' planner_settings.yaml are links to config/'s.
    wj_install_conffile(planner_server ${WJ_CONFIG_DIR}/planner_settings.yaml
                        ${WJ_ETC_DIR}/profiles/${profile})
  endforeach()
  install(FILES ${WJ_DEPLOY_DIR}/systemd/wheeljump-planner.service DESTINATION ${WJ_UNIT_DIR}
          COMPONENT planner_server)
  install(FILES ${PROJECT_SOURCE_DIR}/docs/service.md ${PROJECT_SOURCE_DIR}/docs/install.md
          DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/wheeljump-planner-server COMPONENT planner_server)
endif()

# --- wheeljump-robot-client: the binary when it is built; the profiles and the unit always
# describe it, so the package is made only together with the binary.
if(TARGET robot_client)
  install(TARGETS robot_client RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT robot_client)
  foreach(profile ${WJ_PROFILES})
    wj_install_conffile(robot_client ${WJ_DEPLOY_DIR}/profiles/${profile}/robot_client.env
                        ${WJ_ETC_DIR}/profiles/${profile})
    # The client's own configuration files, the same in every profile (the profile's
    # difference is the planner address in robot_client.env).
    foreach(file robot_client.yaml can.yaml)
      if(EXISTS ${WJ_CONFIG_DIR}/${file})
        wj_install_conffile(robot_client ${WJ_CONFIG_DIR}/${file} ${WJ_ETC_DIR}/profiles/${profile})
      endif()
    endforeach()
  endforeach()
  install(FILES ${WJ_DEPLOY_DIR}/systemd/wheeljump-robot-client.service DESTINATION ${WJ_UNIT_DIR}
          COMPONENT robot_client)
  install(FILES ${PROJECT_SOURCE_DIR}/docs/hardware-safety.md
          DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/wheeljump-robot-client COMPONENT robot_client)
endif()

# --- control files: conffiles and maintainer scripts per package
set(WJ_DEB_COMPONENTS common)
if(TARGET planner_server)
  list(APPEND WJ_DEB_COMPONENTS planner_server)
endif()
if(TARGET robot_client)
  list(APPEND WJ_DEB_COMPONENTS robot_client)
endif()
# What deploy/build-debs.sh asks of this build: `wj_packaged` builds every binary a package
# installs, and wj_deb_packages.txt names the packages CPack must produce (one per line), so the
# script neither guesses targets from a listing nor misses a package that was dropped.
add_custom_target(wj_packaged)
foreach(target planner_server planner_cli robot_client)
  if(TARGET ${target})
    add_dependencies(wj_packaged ${target})
  endif()
endforeach()
set(WJ_DEB_PACKAGES "")
foreach(component ${WJ_DEB_COMPONENTS})
  string(REPLACE "_" "-" folder ${component})
  list(APPEND WJ_DEB_PACKAGES wheeljump-${folder})
endforeach()
list(JOIN WJ_DEB_PACKAGES "\n" lines)
file(WRITE ${PROJECT_BINARY_DIR}/wj_deb_packages.txt "${lines}\n")
foreach(component ${WJ_DEB_COMPONENTS})
  string(REPLACE "_" "-" folder ${component})
  string(TOUPPER ${component} upper)
  set(dir ${WJ_DEB_CONTROL_DIR}/${folder})
  set(extra "")
  foreach(script preinst postinst prerm postrm)
    if(EXISTS ${WJ_DEPLOY_DIR}/debian/${folder}/${script})
      configure_file(${WJ_DEPLOY_DIR}/debian/${folder}/${script} ${dir}/${script} COPYONLY)
      list(APPEND extra ${dir}/${script})
    endif()
  endforeach()
  if(WJ_CONFFILES_${component})
    list(JOIN WJ_CONFFILES_${component} "\n" lines)
    file(WRITE ${dir}/conffiles "${lines}\n")
    list(APPEND extra ${dir}/conffiles)
  endif()
  set(CPACK_DEBIAN_${upper}_PACKAGE_CONTROL_EXTRA "${extra}")
endforeach()

# --- CPack
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME wheeljump)
set(CPACK_PACKAGE_VENDOR "wheeljump")
set(CPACK_PACKAGE_CONTACT "wheeljump maintainers <maintainers@wheeljump.invalid>")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
# Each package's description (CPACK_DEBIAN_<COMPONENT>_DESCRIPTION) starts with its own summary
# line, so CPACK_PACKAGE_DESCRIPTION_SUMMARY stays unset (CPack would prepend it).
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/packages)
# /etc and /lib/systemd are absolute destinations: stage through DESTDIR with prefix /usr.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
# Depends of each package includes the packages of CPACK_COMPONENT_<C>_DEPENDS, same version.
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS ON)
set(CPACK_COMPONENTS_ALL ${WJ_DEB_COMPONENTS})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://wheeljump.invalid")
# Runtime dependencies of the binaries come from dpkg-shlibdeps (dpkg-dev).
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

set(CPACK_DEBIAN_COMMON_PACKAGE_NAME wheeljump-common)
set(CPACK_DEBIAN_COMMON_PACKAGE_ARCHITECTURE all)
string(CONCAT CPACK_DEBIAN_COMMON_DESCRIPTION
    "wheeljump: robot description and configuration profiles\n"
    "The robot's URDF and actuator torque-speed table (/usr/share/wheeljump/models), the\n"
    "profile folders /etc/wheeljump/profiles/{nuc,workstation} and wheeljump-profile, which\n"
    "selects one.")

set(CPACK_DEBIAN_PLANNER_SERVER_PACKAGE_NAME wheeljump-planner-server)
set(CPACK_COMPONENT_PLANNER_SERVER_DEPENDS common)
set(CPACK_DEBIAN_PLANNER_SERVER_PACKAGE_RECOMMENDS systemd)
string(CONCAT CPACK_DEBIAN_PLANNER_SERVER_DESCRIPTION
    "wheeljump: jump planning service (gRPC)\n"
    "planner_server plans take-offs with Differential Evolution over a planar rigid-body model,\n"
    "verifies them in a Simbody simulation and caches them by run-up speed in SQLite.\n"
    "planner_cli queries it. Runs as the hardened systemd unit wheeljump-planner.service.")

set(CPACK_DEBIAN_ROBOT_CLIENT_PACKAGE_NAME wheeljump-robot-client)
set(CPACK_COMPONENT_ROBOT_CLIENT_DEPENDS common)
set(CPACK_DEBIAN_ROBOT_CLIENT_PACKAGE_RECOMMENDS "systemd, can-utils, iproute2")
string(CONCAT CPACK_DEBIAN_ROBOT_CLIENT_DESCRIPTION
    "wheeljump: on-robot client\n"
    "robot_client runs the 1 kHz control loop, the centroidal NMPC and the jump state machine\n"
    "on the Simbody robot or on MIT-mode motors over SocketCAN. The unit\n"
    "wheeljump-robot-client.service has real-time limits; it is never started by the package.")

include(CPack)
