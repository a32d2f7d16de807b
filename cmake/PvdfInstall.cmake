# `cmake --install BUILD [--prefix P] [--component lookup]`: the lookup runtime as a CMake package
#   P/lib/libpvdf_lookup.a, libpvdf_core_io.a          the runtime and the part of core it needs
#   P/include/pvdf/mapping/*.hpp, pvdf/core/{error,io,membrane_scaling}.hpp
#   P/lib/cmake/pvdfkit/pvdfkitConfig.cmake, ...ConfigVersion.cmake, pvdfkit-lookup-targets*.cmake
# so that find_package(pvdfkit) gives pvdf::lookup (examples/deploy builds against it). The Python
# package is the separate component `python` (python/CMakeLists.txt).
include(CMakePackageConfigHelpers)
set(PVDF_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/pvdfkit)

install(TARGETS pvdf_lookup pvdf_core_io EXPORT pvdfkit_lookup_targets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT lookup
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT lookup
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/mapping/lookup/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT lookup)
install(FILES ${PROJECT_SOURCE_DIR}/core/include/pvdf/core/error.hpp ${PROJECT_SOURCE_DIR}/core/include/pvdf/core/io.hpp
              ${PROJECT_SOURCE_DIR}/core/include/pvdf/core/membrane_scaling.hpp
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/pvdf/core COMPONENT lookup)
install(EXPORT pvdfkit_lookup_targets NAMESPACE pvdf:: FILE pvdfkit-lookup-targets.cmake
        DESTINATION ${PVDF_CMAKE_INSTALL_DIR} COMPONENT lookup)

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/pvdfkitConfig.cmake.in
  ${PROJECT_BINARY_DIR}/generated/pvdfkitConfig.cmake INSTALL_DESTINATION ${PVDF_CMAKE_INSTALL_DIR})
# 0.x: a new minor version may change the API, so only the same minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/generated/pvdfkitConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/generated/pvdfkitConfig.cmake ${PROJECT_BINARY_DIR}/generated/pvdfkitConfigVersion.cmake
        DESTINATION ${PVDF_CMAKE_INSTALL_DIR} COMPONENT lookup)
