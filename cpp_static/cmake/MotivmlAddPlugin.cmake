# motivml_add_plugin(<name> SOURCES <file>... [OUTPUT_DIRECTORY <dir>] [ALLOW_UNDEFINED])
#
# A feature built as a plugin: a MODULE library that ROS class_loader loads at run time
# (Debian: libclass-loader-dev), its class registered by MOTIVML_FEATURE(ID, Class) of
# <motivml/feature.hpp> (MOTIVML_PLUGIN_BUILD is defined here). The flags plugins need:
# -fno-gnu-unique, so that unloading really unmaps the library (a hot swap reloads new
# code); -Wl,-z,defs, so that a missing function is a link error and not a crash when it is
# called (ALLOW_UNDEFINED lifts it, for tests of that crash); hidden visibility. The library
# is written into OUTPUT_DIRECTORY (default: the current binary folder), where the plugin's
# plugin.json points.
function(_motivml_class_loader)
  if(TARGET motivml::class_loader)
    return()
  endif()
  # Debian's class_loader CMake config needs ament, so the target is made from its headers.
  find_path(MOTIVML_CLASS_LOADER_INCLUDE class_loader/class_loader.hpp PATH_SUFFIXES class_loader)
  find_path(MOTIVML_RCPPUTILS_INCLUDE rcpputils/shared_library.hpp PATH_SUFFIXES rcpputils)
  find_path(MOTIVML_RCUTILS_INCLUDE rcutils/types.h PATH_SUFFIXES rcutils)
  find_library(MOTIVML_CLASS_LOADER_LIBRARY class_loader)
  find_library(MOTIVML_CONSOLE_BRIDGE_LIBRARY console_bridge)
  find_library(MOTIVML_RCPPUTILS_LIBRARY rcpputils)
  find_library(MOTIVML_RCUTILS_LIBRARY rcutils)
  foreach(part CLASS_LOADER_INCLUDE RCPPUTILS_INCLUDE RCUTILS_INCLUDE CLASS_LOADER_LIBRARY
               CONSOLE_BRIDGE_LIBRARY RCPPUTILS_LIBRARY RCUTILS_LIBRARY)
    if(NOT MOTIVML_${part})
      message(FATAL_ERROR "motivml_add_plugin: ROS class_loader was not found (${part}): "
                          "install it (Debian, Ubuntu: apt-get install libclass-loader-dev) "
                          "or put its prefix on CMAKE_PREFIX_PATH")
    endif()
  endforeach()
  add_library(motivml::class_loader INTERFACE IMPORTED GLOBAL)
  set_target_properties(motivml::class_loader PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES
      "${MOTIVML_CLASS_LOADER_INCLUDE};${MOTIVML_RCPPUTILS_INCLUDE};${MOTIVML_RCUTILS_INCLUDE}"
    INTERFACE_LINK_LIBRARIES
      "${MOTIVML_CLASS_LOADER_LIBRARY};${MOTIVML_CONSOLE_BRIDGE_LIBRARY};${MOTIVML_RCPPUTILS_LIBRARY};${MOTIVML_RCUTILS_LIBRARY}")
endfunction()

function(motivml_add_plugin name)
  cmake_parse_arguments(ARG "ALLOW_UNDEFINED" "OUTPUT_DIRECTORY" "SOURCES" ${ARGN})
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "motivml_add_plugin(${name}): SOURCES is required")
  endif()
  _motivml_class_loader()
  add_library(${name} MODULE ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE motivml::feature motivml::class_loader)
  target_compile_definitions(${name} PRIVATE MOTIVML_PLUGIN_BUILD)
  target_compile_options(${name} PRIVATE -fno-gnu-unique)
  set_target_properties(${name} PROPERTIES
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON
    POSITION_INDEPENDENT_CODE ON)
  if(NOT ARG_ALLOW_UNDEFINED)
    target_link_options(${name} PRIVATE -Wl,-z,defs)
  endif()
  if(ARG_OUTPUT_DIRECTORY)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY "${ARG_OUTPUT_DIRECTORY}")
  endif()
endfunction()
