# volux as a library others build on (docs/API.md): the shared library, the
# installed static archive, install rules, volux.pc and the CMake package.
# Included by the top-level CMakeLists.txt after the layer objects and the
# internal archive `volux` exist; uses VOLUX_OBJECTS and the found packages.

# ---------------------------------------------------------------- shared library
# libvolux.so.<version>, SONAME libvolux.so.<VOLUX_SOVERSION>; only VOLUX_API
# symbols are exported (CMAKE_C_VISIBILITY_PRESET hidden).
add_library(volux_shared SHARED ${VOLUX_OBJECTS})
set_target_properties(volux_shared PROPERTIES OUTPUT_NAME volux LINKER_LANGUAGE C
                      VERSION ${PROJECT_VERSION} SOVERSION ${VOLUX_SOVERSION})
target_include_directories(volux_shared PUBLIC $<BUILD_INTERFACE:${CMAKE_SOURCE_DIR}/include>)
# The same dependencies as the internal archive, whatever a later change adds
# to it (read at generate time).
target_link_libraries(volux_shared PRIVATE $<TARGET_PROPERTY:volux,INTERFACE_LINK_LIBRARIES>)
if(VOLUX_HAVE_GDCM)
  # The C++ adapter instantiates inline functions of GDCM's and the C++
  # library's headers with default visibility: only volux_* is exported.
  file(WRITE ${CMAKE_BINARY_DIR}/volux_exports.map "{ global: volux_*; local: *; };\n")
  target_link_options(volux_shared PRIVATE -Wl,--version-script=${CMAKE_BINARY_DIR}/volux_exports.map)
endif()
if(NOT VOLUX_FUZZ)
  # Every dependency is named at link time, so `ldd` tells the whole story.
  target_link_options(volux_shared PRIVATE -Wl,--no-undefined)
endif()

# ---------------------------------------------------------------- installed static archive
# The internal archive keeps hidden symbols global (white-box tests call
# them). The installed one is one relocatable object whose hidden symbols are
# made local, so a program that links it statically sees exactly the symbols
# the shared library exports and none of our internal names can clash with
# its own (tests/library/check_exports.sh checks both).
set(VOLUX_DIST_DIR ${CMAKE_BINARY_DIR}/dist)
set(VOLUX_DIST_STATIC ${VOLUX_DIST_DIR}/libvolux.a)
add_custom_command(
  OUTPUT ${VOLUX_DIST_STATIC}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${VOLUX_DIST_DIR}
  COMMAND ${CMAKE_COMMAND} -E rm -f ${VOLUX_DIST_STATIC} ${VOLUX_DIST_DIR}/volux_all.o
  COMMAND ${CMAKE_LINKER} -r -o ${VOLUX_DIST_DIR}/volux_all.o ${VOLUX_OBJECTS}
  COMMAND ${CMAKE_OBJCOPY} --localize-hidden ${VOLUX_DIST_DIR}/volux_all.o
  # (with the DICOM adapter: inline GDCM/C++ header functions it instantiates
  # have default visibility; only the ABI's symbols stay global)
  COMMAND ${CMAKE_OBJCOPY} $<$<BOOL:${VOLUX_HAVE_GDCM}>:--keep-global-symbols=${CMAKE_SOURCE_DIR}/abi/volux.symbols>
          ${VOLUX_DIST_DIR}/volux_all.o
  COMMAND ${CMAKE_AR} qc ${VOLUX_DIST_STATIC} ${VOLUX_DIST_DIR}/volux_all.o
  COMMAND ${CMAKE_RANLIB} ${VOLUX_DIST_STATIC}
  DEPENDS ${VOLUX_OBJECTS}
  COMMENT "Linking the installable static archive dist/libvolux.a"
  COMMAND_EXPAND_LISTS VERBATIM)
add_custom_target(volux_dist_static ALL DEPENDS ${VOLUX_DIST_STATIC})
# The object files are other targets' outputs: build those targets first
# (a file-level DEPENDS alone has no rule to make them in a fresh tree).
get_property(VOLUX_LAYER_TARGET_LIST GLOBAL PROPERTY VOLUX_LAYER_TARGETS)
add_dependencies(volux_dist_static ${VOLUX_LAYER_TARGET_LIST})

# ---------------------------------------------------------------- what a static link needs
# The same dependency list feeds volux.pc (Libs.private) and the CMake
# package's static target, so the two cannot drift apart. A library added to
# `volux`'s link must be added here too: check_install.sh's static builds
# fail with its undefined symbols otherwise.
set(VOLUX_STATIC_DEP_FILES ${OpenMP_C_LIBRARIES} ${PNG_LIBRARIES} ${ZLIB_LIBRARIES} ${CJSON_LINK_LIBRARIES} ${EXPAT_LINK_LIBRARIES}
    ${OPENEXR_CORE_LIB} ${MATH_LIB})
if(VOLUX_HAVE_GDCM)
  # the DICOM adapter (src/io/dicom_gdcm.cxx): GDCM and the C++ runtime
  foreach(lib gdcmMSFF gdcmDSED gdcmCommon)
    find_library(VOLUX_${lib}_FILE ${lib} HINTS ${GDCM_LIBRARY_DIRS})
    list(APPEND VOLUX_STATIC_DEP_FILES ${VOLUX_${lib}_FILE})
  endforeach()
  list(APPEND VOLUX_STATIC_DEP_FILES stdc++)
endif()
list(REMOVE_DUPLICATES VOLUX_STATIC_DEP_FILES)
set(VOLUX_PC_LIBS_PRIVATE "")
foreach(lib ${VOLUX_STATIC_DEP_FILES})
  get_filename_component(name ${lib} NAME)
  string(REGEX REPLACE "^lib" "" name "${name}")
  string(REGEX REPLACE "\\.(so|a)(\\..*)?$" "" name "${name}")
  string(APPEND VOLUX_PC_LIBS_PRIVATE " -l${name}")
endforeach()
string(STRIP "${VOLUX_PC_LIBS_PRIVATE}" VOLUX_PC_LIBS_PRIVATE)

# ---------------------------------------------------------------- install
# Layout under the prefix (GNUInstallDirs):
#   bin/volux                          the CLI
#   include/volux/*.h                  the public headers (nothing else)
#   <libdir>/libvolux.so.X.Y.Z, libvolux.so.<soversion>, libvolux.so, libvolux.a
#   <libdir>/pkgconfig/volux.pc
#   <libdir>/cmake/volux/voluxConfig.cmake, voluxConfigVersion.cmake
#   <libdir>/python3/dist-packages/volux/  (VOLUX_PYTHON_DIR; python/)
#   share/doc/volux/examples/          examples/
install(TARGETS volux_shared LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(FILES ${VOLUX_DIST_STATIC} DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${CMAKE_SOURCE_DIR}/include/volux DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h")

# volux.pc names the real prefix, which `cmake --install --prefix P` may
# change after configuration: the template is filled now except for the
# prefix, and completed at install time.
set(VOLUX_PC_PREFIX "@VOLUX_PC_PREFIX@")
configure_file(${CMAKE_SOURCE_DIR}/cmake/volux.pc.in ${VOLUX_DIST_DIR}/volux.pc.in @ONLY)
install(CODE "set(VOLUX_PC_PREFIX \"\${CMAKE_INSTALL_PREFIX}\")
  configure_file(\"${VOLUX_DIST_DIR}/volux.pc.in\" \"${VOLUX_DIST_DIR}/volux.pc\" @ONLY)")
install(FILES ${VOLUX_DIST_DIR}/volux.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# The CMake package: relocatable (paths relative to the config file).
include(CMakePackageConfigHelpers)
set(VOLUX_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/volux)
set(VOLUX_STATIC_DEPS "${VOLUX_STATIC_DEP_FILES}")
configure_package_config_file(${CMAKE_SOURCE_DIR}/cmake/voluxConfig.cmake.in ${VOLUX_DIST_DIR}/voluxConfig.cmake
                              INSTALL_DESTINATION ${VOLUX_CMAKE_DIR}
                              PATH_VARS CMAKE_INSTALL_INCLUDEDIR CMAKE_INSTALL_LIBDIR)
# 0.x: only the same MINOR is compatible (as the SONAME says); 1.x: same MAJOR.
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(VOLUX_COMPAT SameMinorVersion)
else()
  set(VOLUX_COMPAT SameMajorVersion)
endif()
write_basic_package_version_file(${VOLUX_DIST_DIR}/voluxConfigVersion.cmake COMPATIBILITY ${VOLUX_COMPAT})
install(FILES ${VOLUX_DIST_DIR}/voluxConfig.cmake ${VOLUX_DIST_DIR}/voluxConfigVersion.cmake
        DESTINATION ${VOLUX_CMAKE_DIR})

# The Python package (python/volux), plus _install.py naming the installed
# library so `import volux` finds it without LD_LIBRARY_PATH.
set(VOLUX_PYTHON_DIR lib/python3/dist-packages CACHE STRING
    "Where `make install` puts the Python package, relative to the prefix (Debian's layout)")
install(DIRECTORY ${CMAKE_SOURCE_DIR}/python/volux DESTINATION ${VOLUX_PYTHON_DIR}
        PATTERN "__pycache__" EXCLUDE PATTERN "_install.py" EXCLUDE)
install(CODE "file(WRITE \"${VOLUX_DIST_DIR}/_install.py\"
  \"# Written by cmake --install: where this package's libvolux.so lives.\\nLIBDIR = r'\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}'\\n\")")
install(FILES ${VOLUX_DIST_DIR}/_install.py DESTINATION ${VOLUX_PYTHON_DIR}/volux)

# Examples go to the documentation folder as sources.
install(DIRECTORY ${CMAKE_SOURCE_DIR}/examples/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)
