# Finds CHOLMOD (SuiteSparse) and defines the imported target aqs::cholmod.
# Debian 12 ships SuiteSparse 5.12 without CMake configs, hence this small module.
find_path(AQS_CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(AQS_CHOLMOD_LIBRARY NAMES cholmod)
find_library(AQS_SUITESPARSECONFIG_LIBRARY NAMES suitesparseconfig)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(AqsCholmod DEFAULT_MSG
  AQS_CHOLMOD_LIBRARY AQS_SUITESPARSECONFIG_LIBRARY AQS_CHOLMOD_INCLUDE_DIR)
if(AqsCholmod_FOUND AND NOT TARGET aqs::cholmod)
  add_library(aqs::cholmod UNKNOWN IMPORTED)
  set_target_properties(aqs::cholmod PROPERTIES
    IMPORTED_LOCATION "${AQS_CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${AQS_CHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${AQS_SUITESPARSECONFIG_LIBRARY}")
endif()
mark_as_advanced(AQS_CHOLMOD_INCLUDE_DIR AQS_CHOLMOD_LIBRARY AQS_SUITESPARSECONFIG_LIBRARY)
