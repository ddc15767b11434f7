# The version of the motivml CMake package: the Python package's (pyproject.toml; a test
# keeps them equal). A request for the same major version and no newer a version is met.
set(PACKAGE_VERSION "0.1.0")
if(PACKAGE_FIND_VERSION)
  string(REGEX MATCH "^[0-9]+" _motivml_major "${PACKAGE_VERSION}")
  if(PACKAGE_FIND_VERSION VERSION_GREATER PACKAGE_VERSION OR NOT PACKAGE_FIND_VERSION_MAJOR EQUAL _motivml_major)
    set(PACKAGE_VERSION_COMPATIBLE FALSE)
  else()
    set(PACKAGE_VERSION_COMPATIBLE TRUE)
    if(PACKAGE_FIND_VERSION VERSION_EQUAL PACKAGE_VERSION)
      set(PACKAGE_VERSION_EXACT TRUE)
    endif()
  endif()
endif()
