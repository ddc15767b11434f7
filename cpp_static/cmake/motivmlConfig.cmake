# The motivml CMake package: find_package(motivml CONFIG REQUIRED) with the folder
# `motivml cmake-dir` prints on CMAKE_PREFIX_PATH (or motivml_DIR set to it). It provides
#
#   motivml::feature                    the C++ feature interface <motivml/feature.hpp>
#                                       (header-only, C++17)
#   motivml_configure(TARGET <target> ROBOT <robot folder> VARIANT <name> [PREFIX <prefix>])
#                                       run `motivml configure` for the target: its generated
#                                       <motivml/static_loader.hpp> compiles in the variant's
#                                       Static Early features
#   motivml_add_plugin(<name> SOURCES <file>... [OUTPUT_DIRECTORY <dir>])
#                                       a feature built as a class_loader plugin, with the
#                                       flags plugins need
#
# Nothing here sets a global flag: everything hangs on targets.
include_guard(GLOBAL)

get_filename_component(_motivml_root "${CMAKE_CURRENT_LIST_DIR}" DIRECTORY)
if(NOT TARGET motivml::feature)
  add_library(motivml::feature INTERFACE IMPORTED)
  set_target_properties(motivml::feature PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${_motivml_root}/include"
    INTERFACE_COMPILE_FEATURES cxx_std_17)
endif()

include("${CMAKE_CURRENT_LIST_DIR}/MotivmlConfigure.cmake")
include("${CMAKE_CURRENT_LIST_DIR}/MotivmlAddPlugin.cmake")
set(motivml_FOUND TRUE)
