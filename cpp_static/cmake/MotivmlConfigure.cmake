# motivml_configure(TARGET <target> ROBOT <robot folder> VARIANT <name> [PREFIX <macro prefix>])
#
# Runs `motivml configure` when CMake configures the project, writes the generated files
# into <binary dir>/motivml/<target>/motivml/ (features.h, static_loader.hpp,
# bindings.yaml, variant.lock.json) and puts the folder above it on the target's include
# path, so code includes <motivml/static_loader.hpp> or <motivml/features.h> (a bare
# "features.h" on the include path would shadow glibc's <features.h>). CMake re-runs it
# when the model or the variant changes; an invalid variant stops the configuration with
# motivml's explanation.
#
#   find_package(motivml CONFIG REQUIRED)   # (it includes this file)
#   motivml_configure(TARGET robot ROBOT ${CMAKE_SOURCE_DIR}/robot VARIANT lab)
function(motivml_configure)
  cmake_parse_arguments(ARG "" "TARGET;ROBOT;VARIANT;PREFIX" "" ${ARGN})
  foreach(required TARGET ROBOT VARIANT)
    if(NOT ARG_${required})
      message(FATAL_ERROR "motivml_configure: ${required} is required")
    endif()
  endforeach()
  if(NOT ARG_PREFIX)
    set(ARG_PREFIX MOTIVML_)
  endif()
  # motivml beside this package when it is installed in a virtual environment (this file is
  # then <env>/lib/pythonX.Y/site-packages/motivml/cmake/), else on PATH.
  find_program(MOTIVML_EXECUTABLE motivml HINTS "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/../../../../../bin")
  if(NOT MOTIVML_EXECUTABLE)
    message(FATAL_ERROR "motivml_configure: the motivml command was not found. Activate the Python "
                        "environment motivml is installed in (so that motivml is on PATH), or pass "
                        "-DMOTIVML_EXECUTABLE=/path/to/motivml to cmake.")
  endif()
  get_filename_component(robot_dir "${ARG_ROBOT}" ABSOLUTE)
  get_filename_component(robot_name "${robot_dir}" NAME)
  # One folder per target: two targets may bind the same variant with different prefixes.
  set(out "${CMAKE_CURRENT_BINARY_DIR}/motivml/${ARG_TARGET}")
  execute_process(
    COMMAND "${MOTIVML_EXECUTABLE}" configure "${robot_dir}" --variant "${ARG_VARIANT}"
            -o "${out}/motivml" --prefix "${ARG_PREFIX}"
    RESULT_VARIABLE status
    OUTPUT_VARIABLE output
    ERROR_VARIABLE output)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "motivml configure ${robot_name} --variant ${ARG_VARIANT} failed:\n${output}")
  endif()
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS
               "${robot_dir}/model.json" "${robot_dir}/variants/${ARG_VARIANT}.json")
  target_include_directories(${ARG_TARGET} PRIVATE "${out}")
  if(TARGET motivml::feature)
    target_link_libraries(${ARG_TARGET} PRIVATE motivml::feature)
  endif()
endfunction()
