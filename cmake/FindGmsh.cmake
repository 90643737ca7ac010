# FindGmsh -- locate Gmsh's C API (Debian's libgmsh-dev: gmshc.h and
# libgmsh.so). Defines Gmsh_FOUND, Gmsh_INCLUDE_DIR and Gmsh_LIBRARY (the
# library file itself, symbolic links resolved: padapt opens it at run
# time, src/geom/gmsh_model.c, rather than linking it).
find_path(Gmsh_INCLUDE_DIR NAMES gmshc.h)
find_library(Gmsh_LIBRARY_LINK NAMES gmsh)
if(Gmsh_LIBRARY_LINK)
  get_filename_component(Gmsh_LIBRARY "${Gmsh_LIBRARY_LINK}" REALPATH)
endif()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Gmsh REQUIRED_VARS Gmsh_INCLUDE_DIR
  Gmsh_LIBRARY)
mark_as_advanced(Gmsh_INCLUDE_DIR Gmsh_LIBRARY_LINK)
