# FindPTScotch -- locate PT-Scotch (Debian's libptscotch-dev ships no CMake or
# pkg-config file). Defines PTScotch_FOUND and the imported target
# PTScotch::PTScotch (ptscotch, scotch, ptscotcherr, m).
find_path(PTScotch_INCLUDE_DIR NAMES scotch/ptscotch.h ptscotch.h)
find_library(PTScotch_ptscotch_LIBRARY NAMES ptscotch)
find_library(PTScotch_scotch_LIBRARY NAMES scotch)
find_library(PTScotch_ptscotcherr_LIBRARY NAMES ptscotcherr)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(PTScotch REQUIRED_VARS
  PTScotch_INCLUDE_DIR PTScotch_ptscotch_LIBRARY PTScotch_scotch_LIBRARY
  PTScotch_ptscotcherr_LIBRARY)
if(PTScotch_FOUND AND NOT TARGET PTScotch::PTScotch)
  add_library(PTScotch::PTScotch INTERFACE IMPORTED)
  set_target_properties(PTScotch::PTScotch PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${PTScotch_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${PTScotch_ptscotch_LIBRARY};${PTScotch_scotch_LIBRARY};${PTScotch_ptscotcherr_LIBRARY};m")
endif()
mark_as_advanced(PTScotch_INCLUDE_DIR PTScotch_ptscotch_LIBRARY
  PTScotch_scotch_LIBRARY PTScotch_ptscotcherr_LIBRARY)
